"""``psmat profiles`` as a person runs it: the table of shipped profiles, one profile as TOML that
reads back to the same profile, and one line with exit status 1 for a name or file that is not one."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from psmat.profile import Profile, load_profile, profile_names

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

PSMAT = str(Path(sys.executable).parent / "psmat")  # the installed console script


def _psmat(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    # a hang guard, not a timing
    return subprocess.run([PSMAT, "profiles", *args], cwd=cwd, capture_output=True, text=True, timeout=120,
                          check=False)


def test_the_table_names_every_shipped_profile(tmp_path: Path) -> None:
    out = _psmat(cwd=tmp_path)
    assert out.returncode == 0 and out.stderr == "", out.stderr
    lines = out.stdout.splitlines()
    assert lines[0].split()[:3] == ["name", "kind", "shape"] and "pitch (cm)" in lines[0] and "rate (Hz)" in lines[0]
    names = profile_names()
    assert {"psm16", "psm16-v0", "psm8", "daq", "imu", "arduino16"} <= set(names)
    assert [line.split()[0] for line in lines[1:]] == names
    psm8 = next(line for line in lines if line.startswith("psm8 ")).split()
    assert psm8[1:6] == ["psm", "8x8", "4", "v2", "100"]  # kind, shape, pitch cm, protocol, rate Hz


@pytest.mark.parametrize("name", ["psm16", "daq"])
def test_one_profile_prints_as_toml_that_reads_back(tmp_path: Path, name: str) -> None:
    out = _psmat(name, cwd=tmp_path)
    assert out.returncode == 0 and out.stderr == "", out.stderr
    assert out.stdout.splitlines()[0] == f"# source: builtin:{name}"
    assert Profile.from_dict(tomllib.loads(out.stdout)) == load_profile(name)
    # the printed text is a profile file of its own
    mine = tmp_path / "mine.toml"
    mine.write_text(out.stdout, encoding="utf-8")
    again = _psmat(str(mine), cwd=tmp_path)
    assert again.returncode == 0 and again.stdout.splitlines()[1:] == out.stdout.splitlines()[1:]
    assert again.stdout.splitlines()[0] == f"# source: {mine}"


@pytest.mark.parametrize("arg, words", [("psm99", ["no profile named 'psm99'", "psm16"]),
                                        ("missing.toml", ["missing.toml", "no such profile file"]),
                                        ("bad.toml", ["bad.toml", "geometry.pich_cm", "unknown key"])])
def test_not_a_profile_is_one_line_and_exit_1(tmp_path: Path, arg: str, words: list[str]) -> None:
    text = load_profile("psm16").to_toml().replace("pitch_cm = 2.0", "pich_cm = 2.0")
    (tmp_path / "bad.toml").write_text(text, encoding="utf-8")
    out = _psmat(arg, cwd=tmp_path)
    assert out.returncode == 1 and out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("psmat profiles: "), out.stderr
    assert all(w in lines[0] for w in words), lines[0]
