"""Command-line errors: one line on stderr, exit status 1, no file written.

Every subcommand that takes a shape, a duration or an output path is checked; the values are
parsed by the shared argument types of ``psmat.commands._args``, before any device is opened.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from psmat.cli import main
from psmat.io import load_session

PSMAT = str(Path(sys.executable).parent / "psmat")  # the installed console script

# (argv, words the one line must contain); {out} is a file the command must not create. A
# command line that gets past the check stops by itself (--seconds), so a regression fails
# instead of recording until Ctrl-C.
BAD_COMMAND_LINES = [
    # --shape without columns: an IndexError traceback from the twin before
    (["record", "--simulate", "-o", "{out}", "--shape", "16", "--seconds", "1"], ["--shape", "16x16"]),
    (["calibrate", "--simulate", "--shape", "16", "--out", "{out}"], ["--shape", "16x16"]),
    (["simulate", "--shape", "16", "--duration", "1"], ["--shape", "16x16"]),
    (["view", "--simulate", "--shape", "16", "--seconds", "1", "--save", "{out}"], ["--shape", "16x16"]),
    (["demo", "--shape", "16", "--seconds", "1", "--out", "{out}", "--session", "{out}.h5"], ["--shape", "16x16"]),
    (["record", "--simulate", "-o", "{out}", "--shape", "1x16", "--seconds", "1"], ["--shape", "2 ... 255"]),
    (["simulate", "--shape", "16xa"], ["--shape", "16x16"]),
    # --seconds -1: an empty session and exit status 0 before
    (["record", "--simulate", "-o", "{out}", "--seconds", "-1"], ["--seconds", "> 0"]),
    (["calibrate", "--simulate", "--seconds", "-1", "--out", "{out}"], ["--seconds", "> 0"]),
    (["view", "--simulate", "--seconds", "-1", "--save", "{out}"], ["--seconds", "> 0"]),
    (["demo", "--seconds", "-1", "--out", "{out}", "--session", "{out}.h5"], ["--seconds", "> 0"]),
    (["simulate", "--duration", "-1"], ["--duration", "> 0"]),
    (["record", "--simulate", "-o", "{out}", "--seconds", "nan"], ["--seconds", "> 0"]),
    (["record", "--simulate", "-o", "{out}", "--seconds", "soon"], ["--seconds", "number"]),
    (["record", "--simulate", "-o", "{out}", "--rate", "0", "--seconds", "1"], ["--rate", "> 0"]),
    (["demo", "--rate", "0", "--out", "{out}", "--session", "{out}.h5"], ["--rate", ">= 1"]),
    # missing or unknown arguments: argparse's usage block and exit status 2 before
    (["record", "--simulate"], ["-o/--out", "required"]),
    (["record", "--simulate", "-o", "{out}", "--frobnicate", "--seconds", "1"], ["--frobnicate"]),
    ([], ["command"]),
    (["dance"], ["dance"]),
    # neither PORT nor --simulate: exit status 2 before
    (["record", "-o", "{out}", "--seconds", "1"], ["PORT or --simulate"]),
    (["calibrate", "--out", "{out}"], ["PORT or --simulate"]),
]


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.parametrize("argv, words", BAD_COMMAND_LINES,
                         ids=[" ".join(a) or "(nothing)" for a, _ in BAD_COMMAND_LINES])
def test_a_bad_command_line_is_one_line_and_status_1(argv, words, tmp_path, capsys):
    out = tmp_path / "out.x"
    args = [a.format(out=out) for a in argv]
    assert main(args) == 1
    captured = capsys.readouterr()
    line = _one_line(captured.err)
    prog = "psmat" if not args or args[0] == "dance" else f"psmat {args[0]}"
    assert line.startswith(f"{prog}: "), line
    for w in words:
        assert w in line, (w, line)
    assert "Traceback" not in captured.err and captured.out == ""
    assert list(tmp_path.iterdir()) == []  # nothing written, not even an empty file


@pytest.mark.parametrize("existing", ["out.h5", "out.h5.journal"])
def test_record_refuses_an_existing_output_and_names_the_option(existing, tmp_path, capsys):
    out = tmp_path / "out.h5"
    (tmp_path / existing).write_bytes(b"somebody's data")
    assert main(["record", "--simulate", "-o", str(out), "--seconds", "1"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("psmat record: ") and existing in line
    assert "--overwrite" in line and "overwrite=True" not in line  # the option, not the Python argument
    assert (tmp_path / existing).read_bytes() == b"somebody's data"
    assert sorted(p.name for p in tmp_path.iterdir()) == [existing]


def test_record_overwrite_replaces_the_file(tmp_path):
    out = tmp_path / "out.h5"
    out.write_bytes(b"an older take")
    assert main(["record", "--simulate", "-o", str(out), "--seconds", "0.3", "--overwrite"]) == 0
    assert load_session(out).n_frames > 0


@pytest.mark.parametrize("named", [True, False])
def test_calibrate_refuses_an_existing_calibration_before_any_step(named, tmp_path, capsys, monkeypatch):
    """An earlier calibration is somebody's data: kept, refused before the steps, --overwrite named.
    Unnamed, the default file is the twin's serial's (psmat_calibration_<serial>.json)."""
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", "--simulate", "--seconds", "0.2"] + (["--out", "cal.json"] if named else [])) == 0
    written = tmp_path / "cal.json" if named else next(tmp_path.glob("psmat_calibration_*.json"))
    assert "unknown" not in written.name
    before = written.read_bytes()
    capsys.readouterr()
    assert main(["calibrate", "--simulate", "--seconds", "0.2"] + (["--out", "cal.json"] if named else [])) == 1
    captured = capsys.readouterr()
    line = _one_line(captured.err)
    assert line.startswith("psmat calibrate: ") and written.name in line and "--overwrite" in line
    assert "Step 1/2" not in captured.out  # refused before the first step was asked for
    assert written.read_bytes() == before
    assert main(["calibrate", "--simulate", "--seconds", "0.2", "--overwrite"]
                + (["--out", "cal.json"] if named else [])) == 0
    assert [p.name for p in tmp_path.iterdir()] == [written.name]


@pytest.mark.parametrize("argv", [
    ["record", "--simulate", "-o", "{out}", "--shape", "16", "--seconds", "1"],
    ["record", "--simulate", "-o", "{out}", "--seconds", "-1"],
    ["record", "--simulate", "-o", "{existing}", "--seconds", "1"],
])
def test_the_installed_entry_point(argv, tmp_path):
    existing = tmp_path / "existing.h5"
    existing.write_bytes(b"keep me")
    args = [a.format(out=tmp_path / "new.h5", existing=existing) for a in argv]
    proc = subprocess.run([PSMAT, *args], capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 1, proc.stderr
    assert _one_line(proc.stderr).startswith("psmat record: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing.h5"] and existing.read_bytes() == b"keep me"
