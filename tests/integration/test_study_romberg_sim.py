"""The simulated Romberg trial (``psmat study simulate --romberg``, docs/spec.md §7 "Events, conditions, Romberg").

Simulation only: two volunteers, 56 s per condition at 20 Hz (the platform at its own 100 Hz).
56 s keeps each condition's cut of its 60 s BDS source in one piece (no playing back and forth),
so the platform's velocity of each condition is the source's over 55–59 s of its 60 s.

* The three default trials are the same files, bit for bit, with or without ``--romberg``
  (sessions: the same arrays and metadata; HDF5 creation times differ).
* The platform's Romberg quotient of velocity equals the ratio of the BDS authors' published
  ``COPvelo`` of the two source trials (``trials.tsv``, Santos & Duarte 2016), an expectation
  independent of psmat. Tolerance 13 %: over every window of 55–60 s of the 12 firm-surface
  trials shipped with psmat, the mean velocity stays within 6.1 % of the whole trial's
  (computed from those files), so a quotient of two such windows within 1.061/0.939 ≈ 1.13.
* The session's markers cut it, through :func:`psmat.balance.conditions`, into an eyes-open and
  an eyes-closed condition of 56 s each.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from psmat.balance import conditions, romberg, romberg_role, sway
from psmat.io import bds_trials_table, load_forceplate_csv, load_session
from psmat.study import find_study

SECONDS = 56
RATE = 20.0
SEED = 11
DEFAULT = ("right-leg", "left-leg", "rotation")


def _simulate(root: Path, *extra: str) -> Path:
    cmd = [sys.executable, "-m", "psmat", "study", "simulate", str(root), "--volunteers", "2", "--seconds",
           str(SECONDS), "--seed", str(SEED), "--rate", str(RATE), *extra]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return root


@pytest.fixture(scope="module")
def plain(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory.mktemp("plain") / "study")


@pytest.fixture(scope="module")
def with_romberg(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory.mktemp("romberg") / "study", "--romberg")


def test_the_default_trials_are_the_same_files_with_or_without_romberg(plain, with_romberg) -> None:
    files = sorted(p.relative_to(plain) for p in plain.rglob("*") if p.is_file())
    assert len([f for f in files if f.parts[0] == "sessions"]) == 6
    extra = sorted(p.relative_to(with_romberg) for p in with_romberg.rglob("*") if p.is_file()
                   and p.relative_to(with_romberg) not in files)
    assert [str(p) for p in extra] == sorted(f"{d}/{v}_romberg.{x}" for v in ("V01", "V02") for d, x in (
        ("forceplate", "csv"), ("sessions", "h5"), ("truth/sessions", "json"), ("truth/sessions", "npz")))
    for rel in files:
        a, b = plain / rel, with_romberg / rel
        if rel.suffix == ".h5":
            sa, sb = load_session(a), load_session(b)
            for name in ("counts", "valid", "host_time_s", "device_time_us", "seq"):
                np.testing.assert_array_equal(getattr(sa, name), getattr(sb, name), err_msg=f"{rel} {name}")
            assert sa.metadata == sb.metadata and sa.events == sb.events == []
            assert sa.calibration == sb.calibration and sa.device == sb.device
        elif rel == Path("truth/study.json"):
            ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
            assert jb.pop("romberg")["volunteers"].keys() == {"V01", "V02"}
            assert jb.pop("trials") == [*DEFAULT, "romberg"] and ja.pop("trials") == list(DEFAULT)
            assert ja == jb
        else:
            assert a.read_bytes() == b.read_bytes(), rel


def test_the_romberg_session_and_its_markers(with_romberg) -> None:
    layout = find_study(with_romberg)
    assert layout.problems == []
    assert sorted(i.trial for i in layout.items if i.subject == "V01") == sorted([*DEFAULT, "romberg"])
    for vid in ("V01", "V02"):
        s = load_session(with_romberg / "sessions" / f"{vid}_romberg.h5")
        frames = int(SECONDS * RATE)
        assert s.n_frames == 2 * frames and s.metadata["trial"] == "romberg"
        truth = json.loads((with_romberg / "truth" / "sessions" / f"{vid}_romberg.json").read_text())["romberg"]
        assert [label for _, label in s.events] == ["eyes open", "eyes closed"]
        assert [romberg_role(label) for _, label in s.events] == ["EO", "EC"]
        # the markers at the arrival of the first frame and of the first eyes-closed one
        assert s.events[0][0] == s.host_time_s[0] and s.events[1][0] == s.host_time_s[frames]
        assert truth["switch_host_s"] == s.host_time_s[frames] and truth["switch_frame"] == frames
        cond = conditions(s.events, float(s.host_time_s[0]), float(s.host_time_s[-1]))
        assert [c.label for c in cond] == ["eyes open", "eyes closed"]
        # each condition lasts its frames' nominal time (the box's clock is off by at most 1e-3)
        assert cond[0].duration_s == pytest.approx(SECONDS, rel=2e-3)
        assert cond[1].duration_s == pytest.approx(SECONDS - 1 / RATE, rel=2e-3)


def test_the_platform_romberg_quotient_is_the_published_one(with_romberg) -> None:
    table = {r["Trial"]: r for r in bds_trials_table()}
    for vid in ("V01", "V02"):
        info = json.loads((with_romberg / "truth" / "sessions" / f"{vid}_romberg.json").read_text())
        rb = info["romberg"]
        eo_row, ec_row = table[rb["eyes_open"]], table[rb["eyes_closed"]]
        assert (eo_row["Vision"], ec_row["Vision"]) == ("Open", "Closed")
        assert eo_row["Subject"] == ec_row["Subject"] and eo_row["Surface"] == ec_row["Surface"] == "Firm"
        assert not info["eyes_open_part"]["looped"] and not info["eyes_closed_part"]["looped"]
        assert info["sway_scale"] == 1.0  # quiet two-legged sway is played as recorded
        fp = load_forceplate_csv(with_romberg / "forceplate" / f"{vid}_romberg.csv")
        cop = np.column_stack([fp.cop_ml_cm, fp.cop_ap_cm])
        eo = fp.t < rb["switch_platform_s"]
        ec = fp.t >= rb["switch_platform_s"] + rb["blend_s"]
        assert eo.sum() > 55 * 100 and ec.sum() > 54 * 100
        q = romberg(sway(cop[eo], 100.0).as_dict(), sway(cop[ec], 100.0).as_dict())
        published = ec_row["COPvelo"] / eo_row["COPvelo"]
        assert q["romberg_velocity_cm_s"] == pytest.approx(published, rel=0.13)


def test_romberg_needs_eyes_open_and_closed_of_one_subject(tmp_path) -> None:
    from psmat.io import bds_files
    from psmat.synth import simulate_study

    open_only = [f for f in bds_files() if f.name.startswith(("BDS00001", "BDS00002"))]
    with pytest.raises(ValueError, match="romberg needs an eyes-open and an eyes-closed") as e:
        simulate_study(tmp_path / "s", volunteers=1, duration_s=2, seed=0, rate_hz=10, bds_paths=open_only,
                       romberg=True)
    assert "\n" not in str(e.value)
