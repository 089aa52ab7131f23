"""psmat.posture.align_mat_imu: a mat and spine IMUs recorded apart, aligned by their summed signals (thesis Fig. 4.11).

The synthetic session is physical: one trunk-flexion trajectory (the thesis protocol: straight,
forward, back, bounces, slow rocking with a drifting period, bounces) drives both instruments.
The cushion carries a constant share of the body weight plus the bounces' inertial force; leaning
forward brings the thighs' cells into contact, so the same force spreads over more cells, and a
cell's conductance is ``g ∝ p^β`` — the summed conductance rises with flexion for β < 1 and falls
for β > 1. The five IMUs see the flexion through per-sensor curvature offsets and gains, with
noise and slow drift; they do not see the bounces (a vertical motion).
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat.io import load_imu_log, write_imu_log
from psmat.posture.data import MatImuAlignment, align_mat_imu, summed_mat_at_rate

G = 9.81          # m/s²
MASS_KG = 62.0    # thesis Table 4.2: mean weight
SEATED = 0.7      # share of the weight on the cushion (the rest through the legs)
CELL_M2 = 4e-4    # 2 cm × 2 cm cells


def flexion_deg(tau: np.ndarray) -> np.ndarray:
    """Trunk flexion (deg, + forward) over true time (s), the thesis protocol in 200 s."""
    hold = np.interp(tau, [0, 30, 32, 60, 62, 90, 92], [0, 0, 20, 20, -12, -12, 0])
    rocking = np.clip((tau - 112) / 2, 0, 1) * np.clip((170 - tau) / 2, 0, 1)  # 112-170 s, eased in and out
    period = 7.0 + 0.05 * (tau - 112)  # a slowly drifting swing period: no exact periodicity
    return hold + rocking * (16 * np.sin(2 * np.pi * (tau - 112) / period) + 4)


def bounce_ms2(tau: np.ndarray) -> np.ndarray:
    """Vertical acceleration of the trunk (m/s²) during the bounces (92-110 s and from 172 s)."""
    on = ((tau > 92) & (tau < 110)) | (tau > 172)
    return np.where(on, 1.5 * np.sin(2 * np.pi * 1.1 * tau), 0.0)


def seated_session(imu_late_s: float, *, mat_clock0: float = 1000.0, mat_hz: float = 100.0, imu_hz: float = 10.0,
                   beta: float = 0.7, seed: int = 0, seconds: float = 200.0):
    """Mat and IMUs on their own clocks: the mat's reads ``mat_clock0 + τ``; the IMU log starts
    ``imu_late_s`` after the mat, at 0 on its clock (``k / imu_hz``), so it reads ``τ − imu_late_s``.

    Returns t_mat, g (T, 16, 16) S with three invalid frames, t_imu, angles (M, 5, 3) deg, and the
    true lag ``t_imu − t_mat`` at one instant, ``−mat_clock0 − imu_late_s``.
    """
    rng = np.random.default_rng(seed)
    n_mat = int(seconds * mat_hz)
    tau_m = np.arange(n_mat) / mat_hz + np.r_[0.0, rng.uniform(-1e-3, 1e-3, n_mat - 1)]  # host jitter
    force = SEATED * MASS_KG * (G + bounce_ms2(tau_m))
    thresholds = np.linspace(-15.0, 35.0, 60)  # flexion at which each thigh cell comes into contact
    contact = np.concatenate([np.ones((n_mat, 18)),  # ischial tuberosities: always loaded
                              1 / (1 + np.exp(-(flexion_deg(tau_m)[:, None] - thresholds) / 3.0))], axis=1)
    p = force[:, None] * contact / contact.sum(axis=1, keepdims=True) / CELL_M2  # Pa
    g = np.zeros((n_mat, 16, 16))
    g.reshape(n_mat, -1)[:, :78] = 1e-3 * (p / 1e4) ** beta * (1 + 0.03 * rng.standard_normal(p.shape))
    g[[500, 501, n_mat - 300]] = np.nan  # frames lost on the link

    n_imu = int((seconds - imu_late_s - 5.0) * imu_hz)
    t_imu = np.arange(n_imu) / imu_hz
    tau_i = t_imu + imu_late_s
    offset = np.array([-10.0, 5.0, 12.0, 8.0, -15.0])  # curvature of the back at each sensor, deg
    gain = np.array([0.5, 0.8, 1.0, 1.1, 1.2])
    drift = rng.uniform(-0.5, 0.5, 5) / 60.0 * tau_i[:, None]  # up to 0.5 deg a minute
    angles = np.zeros((n_imu, 5, 3))
    angles[:, :, 0] = 90.0 + rng.normal(0.0, 0.5, (n_imu, 5))  # heading
    angles[:, :, 1] = rng.normal(0.0, 0.5, (n_imu, 5))  # roll
    angles[:, :, 2] = offset + gain * flexion_deg(tau_i)[:, None] + drift + rng.normal(0.0, 0.3, (n_imu, 5))
    return mat_clock0 + tau_m, g, t_imu, angles, -mat_clock0 - imu_late_s


@pytest.mark.parametrize("imu_late_s, mat_clock0, mat_hz, imu_hz, beta, seed", [
    (6.37, 1000.0, 100.0, 10.0, 0.7, 0),   # the thesis' rates, concave cells
    (40.0, 1000.0, 100.0, 10.0, 0.7, 1),   # a late IMU: 40 s of the mat without it
    (2.13, -50.0, 73.0, 12.5, 0.7, 2),     # other rates; the IMU clock ahead of the mat's
    (6.37, 1000.0, 100.0, 10.0, 1.4, 3),   # convex cells: summed g falls with flexion
])
def test_a_known_lag_is_recovered_to_one_imu_sample(imu_late_s, mat_clock0, mat_hz, imu_hz, beta, seed) -> None:
    t_mat, g, t_imu, angles, lag = seated_session(imu_late_s, mat_clock0=mat_clock0, mat_hz=mat_hz, imu_hz=imu_hz,
                                                  beta=beta, seed=seed)
    a = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2])
    assert isinstance(a, MatImuAlignment) and not a.manual
    assert a.lag_s == pytest.approx(lag, abs=1.0 / imu_hz)
    assert a.fs_hz == pytest.approx(imu_hz)
    assert a.sign == (1 if beta < 1 else -1) and np.sign(a.r) == a.sign  # the relation's sign, from β
    assert abs(a.r) > 0.8


@pytest.mark.parametrize("mat_clock0, imu_late_s", [(1000.0, 6.37), (-50.0, 2.13)])
def test_lag_sign_convention_mat_time_plus_lag_is_imu_time(mat_clock0, imu_late_s) -> None:
    t_mat, g, t_imu, angles, lag = seated_session(imu_late_s, mat_clock0=mat_clock0, seed=4)
    a = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2])
    # the forward lean starts at τ = 30 s: mat clock mat_clock0 + 30, IMU clock 30 − imu_late_s
    assert a.to_imu_time(mat_clock0 + 30.0) == pytest.approx(30.0 - imu_late_s, abs=0.1)
    assert a.lag_s == pytest.approx(-mat_clock0 - imu_late_s, abs=0.1)
    assert np.sign(a.lag_s) == np.sign(lag)  # negative when the mat's clock is ahead, positive when behind


def test_the_sign_of_the_relation_can_be_imposed() -> None:
    t_mat, g, t_imu, angles, lag = seated_session(6.37, beta=1.4, seed=5)
    free = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2])
    known = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2], sign=-1)
    wrong = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2], sign=1)
    assert known.lag_s == pytest.approx(free.lag_s, abs=1e-9) and known.r == pytest.approx(free.r)
    assert known.sign == -1 and known.r < -0.8
    # searching the wrong sign finds a weaker (positive) correlation elsewhere
    assert wrong.sign == 1 and 0 < wrong.r < abs(known.r)


def test_max_lag_s_is_honoured_even_with_the_true_lag_just_beyond_it() -> None:
    t_mat, g, t_imu, angles, lag = seated_session(6.37, seed=6)
    starts = t_imu[0] - t_mat[0]  # the window is centred on what the starts say
    assert lag - starts == pytest.approx(-6.37)
    assert align_mat_imu(t_mat, g, t_imu, angles[:, :, 2], max_lag_s=8.0).lag_s == pytest.approx(lag, abs=0.1)
    for max_lag in (6.3, 3.0):  # just inside the true offset (the sub-sample refinement pulls outward) and well inside
        a = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2], max_lag_s=max_lag)
        assert abs(a.lag_s - starts) <= max_lag + 1e-9


def test_a_log_recorded_apart_through_the_thesis_text_format(tmp_path) -> None:
    t_mat, g, t_imu, angles, lag = seated_session(6.37, seed=7)
    angles[[15, 16, 900]] = np.nan  # dropouts
    path = write_imu_log(tmp_path / "P01_d1.txt", angles)
    raw = path.read_text().splitlines()
    raw[300] = raw[300][:25]  # a line cut short
    path.write_text("\n".join(raw) + "\n")
    log = load_imu_log(path)
    assert (~log.valid).sum() == 4
    a = align_mat_imu(t_mat, g, log.t_s, log.pitch_deg)  # invalid samples (NaN) are left out
    assert a.lag_s == pytest.approx(lag, abs=0.1)
    # the angles' unit does not matter: radians give the same lag
    assert align_mat_imu(t_mat, g, log.t_s, np.deg2rad(log.pitch_deg)).lag_s == pytest.approx(a.lag_s, abs=1e-6)


def test_the_figure_series_and_the_manual_override() -> None:
    t_mat, g, t_imu, angles, lag = seated_session(6.37, seed=8)
    a = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2])
    # the series are the IMU samples inside the overlap, standardised; their correlation is the r found
    assert a.t_s.shape == a.mat.shape == a.imu.shape and a.t_s.size > 1800
    assert a.t_s[0] - a.lag_s >= t_mat[0] and a.t_s[-1] - a.lag_s <= t_mat[-1]
    np.testing.assert_allclose([a.mat.mean(), a.mat.std(), a.imu.mean(), a.imu.std()], [0, 1, 0, 1], atol=1e-9)
    assert np.corrcoef(a.mat, a.imu)[0, 1] == pytest.approx(a.r, abs=0.02)
    at_truth = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2], lag_s=lag)
    off = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2], lag_s=lag + 2.0)
    assert at_truth.manual and at_truth.lag_s == lag
    assert at_truth.r == pytest.approx(a.r, abs=0.01)
    assert off.r < at_truth.r - 0.1


def test_summed_mat_at_rate_averages_each_interval() -> None:
    # 100 Hz frames of a 2 × 2 mat whose sum is 4·k at frame k, on an 8 Hz grid from the first frame:
    # the interval of grid sample j is [12.5 j − 6.25, 12.5 j + 6.25) frames (no frame on an edge),
    # so its mean is 4 × the mean of the frame indices inside; a lost frame (NaN) is left out
    t = np.arange(1000) / 100.0
    g = np.repeat(np.arange(1000.0)[:, None, None], 2, axis=1).repeat(2, axis=2)
    g[40] = np.nan
    tt, s = summed_mat_at_rate(t, g, 8.0)
    np.testing.assert_allclose(tt, np.arange(80) / 8.0)
    frames = [[k for k in range(int(np.ceil(12.5 * j - 6.25)), int(np.floor(12.5 * j + 6.25)) + 1) if 0 <= k < 1000 and k != 40]
              for j in range(80)]
    np.testing.assert_allclose(s, [4 * np.mean(f) for f in frames])


def test_the_figure(tmp_path) -> None:
    from matplotlib.figure import Figure

    from psmat.posture.data import plot_mat_imu_alignment

    t_mat, g, t_imu, angles, _ = seated_session(6.37, beta=1.4, seed=9)
    a = align_mat_imu(t_mat, g, t_imu, angles[:, :, 2])
    path = tmp_path / "fig411.png"
    fig = plot_mat_imu_alignment(a, path=path)
    assert isinstance(fig, Figure) and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    mat_line, angle_line = fig.axes[0].lines
    np.testing.assert_array_equal(mat_line.get_xdata(), a.t_s)
    np.testing.assert_array_equal(mat_line.get_ydata(), a.mat)
    np.testing.assert_array_equal(angle_line.get_ydata(), -a.imu)  # a negative relation drawn inverted, and said so
    assert "negative" in angle_line.get_label()
    with pytest.raises(TypeError, match="MatImuAlignment"):
        plot_mat_imu_alignment(a.lag_s)  # type: ignore[arg-type]


def _bad(what: str):
    t_mat, g, t_imu, angles, _ = seated_session(6.37, seed=10, seconds=60.0)
    pitch = angles[:, :, 2]
    kwargs: dict = {}
    if what == "g rows":
        g = g[:-1]
    elif what == "t_mat order":
        t_mat = t_mat[::-1].copy()
    elif what == "t_imu order":
        t_imu = t_imu[::-1].copy()
    elif what == "angles 1-D":
        pitch = pitch.sum(axis=1)
    elif what == "few imu":
        t_imu, pitch = t_imu[:5], pitch[:5]
    elif what == "flat mat":
        g = np.ones_like(g)
    elif what == "flat angles":
        pitch = np.ones_like(pitch)
    elif what in ("sign", "sign bool", "max_lag_s", "min_overlap", "no overlap", "lag nan"):
        kwargs = {"sign": 2, "sign bool": True, "max_lag_s": -1.0, "min_overlap": 2.0, "no overlap": 1e4,
                  "lag nan": float("nan")}[what]
        kwargs = {{"sign bool": "sign", "no overlap": "lag_s", "lag nan": "lag_s"}.get(what, what): kwargs}
    return t_mat, g, t_imu, pitch, kwargs


@pytest.mark.parametrize("what, match", [
    ("g rows", "g_mat must have shape"), ("t_mat order", "t_mat must increase"), ("t_imu order", "t_imu must increase"),
    ("angles 1-D", "angles_rad must have shape"), ("few imu", "at least 8"), ("flat mat", "summed mat signal does not change"),
    ("flat angles", "summed angles do not change"), ("sign", "sign must be"), ("sign bool", "sign must be"),
    ("max_lag_s", "max_lag_s"), ("min_overlap", "min_overlap"), ("no overlap", "do not overlap"), ("lag nan", "lag_s"),
])
def test_bad_input_is_one_clear_line(what, match) -> None:
    t_mat, g, t_imu, pitch, kwargs = _bad(what)
    with pytest.raises(ValueError, match=match) as err:
        align_mat_imu(t_mat, g, t_imu, pitch, **kwargs)
    assert "\n" not in str(err.value)
