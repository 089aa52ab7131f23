"""``psmat view`` and ``psmat demo`` take the mat from ``--profile`` (docs/spec.md §5 "Device profiles").

psm8 is the thesis' lower-resolution mat: 8 x 8 cells of 4 cm on the same 32 cm (§3), cell (i, p)
centred at (4 p, 4 i) cm, so its images span -2 ... 30 cm. A mirrored profile (x falling with the
column, cell (0, 0) at (40, 5) cm) must give the same demo, in its own coordinates.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from psmat.io import load_session
from psmat.profile import Geometry, load_profile

PSMAT = str(Path(sys.executable).parent / "psmat")  # the installed console script


def _psmat(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([PSMAT, *argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def test_view_simulates_the_profiles_mat(tmp_path) -> None:
    r = _psmat("view", "--simulate", "--profile", "psm8", "--seconds", "2", "--save", "out.png", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "psm8" in r.stdout  # the twin it serves is the profile's mat
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert " 0 invalid" in r.stdout and int(r.stdout.split(" frames received")[0].split()[-1]) > 0


def test_view_refuses_a_profile_of_another_device_in_one_line(tmp_path) -> None:
    r = _psmat("view", "--simulate", "--profile", "imu", "--seconds", "1", "--save", "out.png", cwd=tmp_path)
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1
    assert "imu" in r.stderr and not (tmp_path / "out.png").exists()


@pytest.mark.slow
def test_demo_records_the_profiles_mat(tmp_path) -> None:
    r = _psmat("demo", "--twin", "--profile", "psm8", "--seconds", "2", "--rate", "50", "--out", "d.png",
               "--session", "d.h5", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "d.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    s = load_session(tmp_path / "d.h5")
    assert s.profile["name"] == "psm8" and s.profile["geometry"]["pitch_cm"] == 4.0
    assert s.counts.shape[1:] == (8, 8) and s.n_frames > 0


@pytest.mark.slow
def test_demo_on_a_mirrored_mat_is_in_its_coordinates(tmp_path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from psmat.workflows.sway_demo import record_sway, sway_figure

    psm16 = load_profile("psm16")
    mirrored = replace(psm16, name="psm16-mirrored",
                       geometry=Geometry((16, 16), 2.0, (40.0, 5.0), "-columns", "+rows"))  # x = 40 - 2 p, y = 5 + 2 i
    rec = record_sway(seconds=2, rate_hz=50, session=tmp_path / "m.h5", progress=False, log=lambda *a: None,
                      profile=mirrored)
    assert rec.session.profile["geometry"]["x"] == "-columns"
    # the mat's CoP and the platform's, both in the mirrored coordinates: a few mm apart (the twin's
    # cell gains), where a CoP left in the scene's coordinates would be about 10 cm off in x and its
    # M-L sway mirrored
    res = rec.res
    assert np.hypot(*res["cop_offset_cm"]) < 0.5
    ok = np.all(np.isfinite(rec.processed.cop_cm), axis=1)
    assert np.all((rec.processed.cop_cm[ok, 0] > 10.0) & (rec.processed.cop_cm[ok, 0] < 40.0))
    ml, ml_true = rec.processed.cop_cm[ok, 0], rec.truth_cm[ok, 0]
    assert np.corrcoef(ml, ml_true)[0, 1] > 0.9
    fig = sway_figure(rec)
    try:
        maps = [ax for ax in fig.axes if ax.get_images()]
        assert len(maps) == 2
        for ax in maps:
            im = ax.get_images()[0]
            assert im.get_extent() == pytest.approx((9.0, 41.0, 4.0, 36.0))  # x centres 10 ... 40, y 5 ... 35 cm
        # the drawn pressure image, read with matplotlib's pixel centres, has the chain's CoP
        im = maps[1].get_images()[0]
        img = np.asarray(im.get_array(), float)
        left, right, bottom, top = im.get_extent()
        xc = left + (np.arange(img.shape[1]) + 0.5) * (right - left) / img.shape[1]
        yc = bottom + (np.arange(img.shape[0]) + 0.5) * (top - bottom) / img.shape[0]
        drawn = (np.sum(img * xc[None, :]) / img.sum(), np.sum(img * yc[:, None]) / img.sum())
        marker = maps[1].lines[0].get_xydata()[0]  # the corrected CoP's marker
        assert drawn == pytest.approx(tuple(marker), abs=1e-6)
    finally:
        plt.close(fig)
