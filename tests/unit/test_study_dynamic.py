"""The dynamic correction of the mat's sway (beyond the thesis): fitted on other volunteers only.

The constructed case: each volunteer's platform trace is band-limited random sway (white noise
through a 4th-order Butterworth low-pass at 3 Hz, SD 0.5 cm per axis); the mat sees it through a
known linear filter, gain G = 0.7 and a first-order low-pass at FC = 1.5 Hz
(``m[n] = α·m[n−1] + (1 − α)·G·fp[n]``, α = exp(−2π·FC/fs)), plus white noise of SD 2e-3 cm.
The exact inverse of that filter, ``fp[n] = (m[n] − α·m[n−1]) / (G·(1 − α))``, applied to the
noisy mat trace is the benchmark a correction learnt from other volunteers must reach.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from psmat.balance import eu
from psmat.study import dynamic_rows, fit_correction
from psmat.study import COLUMNS

FS, G, FC, NOISE_CM, SD_CM = 50.0, 0.7, 1.5, 2e-3, 0.5
FP_OFFSET, MAT_OFFSET = np.array([3.0, -2.0]), np.array([16.0, 15.0])  # absolute traces, own origins


def _alpha(fs: float) -> float:
    return float(np.exp(-2.0 * np.pi * FC / fs))


def _mat_of(fp: np.ndarray, fs: float, rng: np.random.Generator, noise: float = NOISE_CM) -> np.ndarray:
    a = _alpha(fs)
    low = signal.lfilter([1.0 - a], [1.0, -a], fp - fp.mean(axis=0), axis=0)
    return G * low + noise * rng.standard_normal(fp.shape) + MAT_OFFSET


def _study(volunteers: int = 4, seconds: float = 60.0, seed: int = 1, rates=None,
           trials=("right-leg",)) -> tuple[list[dict], dict]:
    rng = np.random.default_rng(seed)
    rows, traces = [], {}
    for v in range(volunteers):
        fs = FS if rates is None else rates[v]
        for trial in trials:
            n = int(seconds * fs)
            sway = signal.sosfilt(signal.butter(4, 3.0, fs=fs, output="sos"), rng.standard_normal((n + 500, 2)), axis=0)
            fp = SD_CM * sway[500:] / sway[500:].std(axis=0) + FP_OFFSET
            key = (f"V{v + 1:02d}", trial)
            traces[key] = {"t_s": 100.0 + np.arange(n) / fs, "FP": fp, "SCHC": _mat_of(fp, fs, rng)}
            rows += [{"subject": key[0], "trial": trial, "variant": name, "status": "ok"} for name in ("FP", "SCHC")]
    return rows, traces


def _centred(c: np.ndarray) -> np.ndarray:
    return c - c.mean(axis=0)


@pytest.fixture(scope="module")
def study():
    return _study()


def test_held_out_traces_recover_the_platform_through_a_known_filter(study) -> None:
    rows, traces = study
    new, fixed = dynamic_rows(rows, traces)
    assert [r["variant"] for r in new] == ["SCHC-DYN"] * 4 and all(r["status"] == "ok" for r in new)
    assert all(set(r) == set(COLUMNS) for r in new)
    a = _alpha(FS)
    for r in new:
        key = (r["subject"], r["trial"])
        t, fp, mat = traces[key]["t_s"], _centred(traces[key]["FP"]), _centred(traces[key]["SCHC"])
        assert np.array_equal(fixed[key]["t_s"], t) and np.array_equal(fixed[key]["FP"], traces[key]["FP"])
        # the exact inverse of the known filter on the noisy trace (by hand, not the fitted model)
        ideal = signal.lfilter([1.0, -a], [G * (1.0 - a)], mat, axis=0)
        eu_base, eu_ideal = eu(mat, fp), eu(_centred(ideal), fp)
        # the case has a large error to remove: the uncorrected trace is ~16x farther than the ideal
        assert eu_base > 10 * eu_ideal
        # held out, the correction is at least as good as the exact inverse (least squares trades
        # the inverse's noise gain, sqrt(1 + α²)/(G(1 − α)) ≈ 11, against bias), 10 % slack
        assert r["eu_cm"] <= 1.1 * eu_ideal
        assert r["eu_cm"] == pytest.approx(eu(_centred(fixed[key]["SCHC-DYN"]), fp), rel=1e-12)
        # σ ratio: the base spreads ~0.5 as much as the platform (G·|H| over the sway's band);
        # corrected, the least-squares residual e is orthogonal to the fit, so σ_fit² = σ_fp² − σ_e²
        # and σ_e/σ_fp ≤ the ideal inverse's relative error (~0.045) gives a ratio ≥ 0.999; 0.01
        # leaves room for the held-out volunteer's own sway differing from the training ones'
        assert r["sd_ml_cm"] / np.std(fp[:, 0], ddof=1) == pytest.approx(1.0, abs=0.01)
        assert r["sd_ap_cm"] / np.std(fp[:, 1], ddof=1) == pytest.approx(1.0, abs=0.01)
        assert np.std(mat, axis=0, ddof=1).max() / np.std(fp, axis=0, ddof=1).min() < 0.6
        # absolute, in the mat's own frame (its mean added back), within a 50th of the sway's SD
        assert np.allclose(fixed[key]["SCHC-DYN"].mean(axis=0), traces[key]["SCHC"].mean(axis=0), atol=0.02 * SD_CM)


def test_each_model_recovers_its_own_constructed_case() -> None:
    rng = np.random.default_rng(3)
    ys = [_centred(signal.sosfilt(signal.butter(4, 3.0, fs=FS, output="sos"), rng.standard_normal((3000, 2)), axis=0))
          for _ in range(3)]
    # a pure gain: the least-squares gain is 1/G exactly without noise
    gain = fit_correction([G * y for y in ys], ys, FS, model="gain")
    assert [float(c[0]) for c in gain.coef] == pytest.approx([1 / G, 1 / G], rel=1e-9)
    # gain and first-order low-pass, no noise: the first-order TF is the exact inverse,
    # b0 = 1/(G(1 − α)), b1 = −α/(G(1 − α)), a1 = 0
    a = _alpha(FS)
    xs = [_centred(_mat_of(y, FS, rng, noise=0.0)) for y in ys]
    tf = fit_correction(xs, ys, FS, model="tf")
    for c in tf.coef:
        assert c[:2] == pytest.approx([1 / (G * (1 - a)), -a / (G * (1 - a))], rel=1e-3)
        assert abs(c[2]) < 1e-3
    fir = fit_correction(xs, ys, FS, model="fir", fir_half_s=0.1)
    assert all(c.size == 11 for c in fir.coef)  # ±0.1 s at 50 Hz: 2·5 + 1 taps
    assert eu(fir.apply(xs[0]), ys[0]) < 0.05 * eu(xs[0], ys[0])


def test_different_rates_are_resampled_to_one() -> None:
    rows, traces = _study(seconds=40.0, rates=(40.0, 47.0, 53.0, 60.0), seed=2)
    new, fixed = dynamic_rows(rows, traces)
    for r in new:
        key = (r["subject"], r["trial"])
        fp, mat = _centred(traces[key]["FP"]), _centred(traces[key]["SCHC"])
        assert fixed[key]["SCHC-DYN"].shape == traces[key]["SCHC"].shape
        # each volunteer's low-pass has its own α at its rate; one model at the median rate (50 Hz)
        # still removes most of the error (linear resampling smooths the 3 Hz band by < 2 %)
        assert r["eu_cm"] < 0.1 * eu(mat, fp)
        assert r["sd_ml_cm"] / np.std(fp[:, 0], ddof=1) == pytest.approx(1.0, abs=0.03)


def test_no_volunteer_corrects_itself_with_its_own_platform(study) -> None:
    rows, traces = study
    absurd = {k: dict(v) for k, v in traces.items()}
    absurd[("V01", "right-leg")]["FP"] = traces[("V01", "right-leg")]["FP"] * 100.0
    for folds, same in ((None, {"V01"}), (2, {"V01", "V03"})):  # 2 folds: V01, V03 | V02, V04
        _, before = dynamic_rows(rows, traces, folds=folds)
        _, after = dynamic_rows(rows, absurd, folds=folds)
        for key in before:
            b, a = before[key]["SCHC-DYN"], after[key]["SCHC-DYN"]
            if key[0] in same:
                assert np.array_equal(a, b)  # fitted on the other fold only: not even a rounding apart
            else:
                assert np.std(a[:, 0]) > 3 * np.std(b[:, 0])  # V01's ×100 platform entered their fit


def test_fewer_than_two_volunteers_give_rows_with_a_status(study) -> None:
    rows, traces = study
    one = [r for r in rows if r["subject"] == "V01"]
    new, fixed = dynamic_rows(one, traces)
    assert fixed == {} and len(new) == 1
    assert new[0]["status"].startswith("not corrected:") and "fewer than 2 volunteers" in new[0]["status"]
    assert np.isnan(new[0]["eu_cm"]) and np.isnan(new[0]["sd_ml_cm"])
    assert dynamic_rows([], {}) == ([], {})


def test_failed_sessions_are_ignored_and_reported(study) -> None:
    rows, traces = study
    _, reference = dynamic_rows([r for r in rows if r["subject"] in ("V01", "V02", "V03")], traces)
    bad = [dict(r) for r in rows]
    for r in bad:
        if r["subject"] == "V04" and r["variant"] == "SCHC":
            r["status"] = "error: SessionFormatError: damaged"
    garbage = {k: dict(v) for k, v in traces.items()}
    garbage[("V04", "right-leg")]["SCHC"] = np.full_like(traces[("V04", "right-leg")]["SCHC"], 1e6)
    new, fixed = dynamic_rows(bad, garbage)
    by = {r["subject"]: r for r in new}
    assert by["V04"]["status"] == "not corrected: SCHC: error: SessionFormatError: damaged"
    assert ("V04", "right-leg") not in fixed
    for key, tr in reference.items():  # V04's trace never entered a fit
        assert np.array_equal(fixed[key]["SCHC-DYN"], tr["SCHC-DYN"])
    # a session without its trace, and one whose platform row failed
    missing = {k: v for k, v in traces.items() if k[0] != "V02"}
    no_fp = [dict(r, status="no force-platform file") if (r["subject"], r["variant"]) == ("V03", "FP") else r
             for r in rows]
    assert {r["subject"]: r["status"] for r in dynamic_rows(no_fp, missing)[0]} == {
        "V01": "ok", "V02": "not corrected: no aligned SCHC and platform traces",
        "V03": "not corrected: FP: no force-platform file", "V04": "ok"}


def test_per_trial_models_need_another_volunteer_with_that_trial() -> None:
    rows, traces = _study(volunteers=3, seconds=20.0, trials=("right-leg", "rotation"))
    rows = [r for r in rows if not (r["trial"] == "rotation" and r["subject"] != "V01")]
    new, _ = dynamic_rows(rows, traces)  # one model per trial type by default
    status = {(r["subject"], r["trial"]): r["status"] for r in new}
    assert status[("V01", "rotation")] == ("not corrected: no other volunteer with a 'rotation' trial to fit on "
                                           "(fewer than 2 volunteers)")
    assert all(s == "ok" for k, s in status.items() if k[1] == "right-leg")
    pooled, _ = dynamic_rows(rows, traces, by_trial=False)  # pooled over trial types: V01's rotation too
    assert all(r["status"] == "ok" for r in pooled)


def test_bad_arguments_are_one_line_errors(study) -> None:
    rows, traces = study
    with pytest.raises(ValueError, match="unknown model 'spline'"):
        dynamic_rows(rows, traces, model="spline")
    with pytest.raises(ValueError, match="folds must be an integer >= 2"):
        dynamic_rows(rows, traces, folds=1)
    with pytest.raises(ValueError, match="rate_hz must be a positive number of Hz"):
        dynamic_rows(rows, traces, rate_hz=0.0)


def test_fir_from_summed_normal_equations_equals_the_stacked_ridge_least_squares() -> None:
    # the FIR is fitted from per-session W'W and W'y; the reference is the ridge problem written
    # out: the lag matrix of every session stacked over sqrt(λ²)·I, solved by scipy's lstsq (SVD)
    from scipy import linalg

    rng = np.random.default_rng(11)
    ys = [_centred(signal.sosfilt(signal.butter(4, 3.0, fs=FS, output="sos"), rng.standard_normal((n, 2)), axis=0))
          for n in (1500, 2200, 900)]
    xs = [_centred(_mat_of(y, FS, rng, noise=0.05)) for y in ys]
    ridge, half = 1e-3, 5  # ±0.1 s at 50 Hz
    fir = fit_correction(xs, ys, FS, model="fir", fir_half_s=0.1, ridge=ridge)
    for k in range(2):
        X = np.concatenate([np.column_stack([np.pad(x[:, k], half, mode="edge")[j:j + len(x)] for j in range(2 * half + 1)])
                            for x in xs])
        lam = np.sqrt(ridge * np.mean(np.sum(X * X, axis=0)))
        A = np.vstack([X, lam * np.eye(X.shape[1])])
        ref = linalg.lstsq(A, np.concatenate([np.concatenate([y[:, k] for y in ys]), np.zeros(X.shape[1])]))[0]
        assert fir.coef[k] == pytest.approx(ref, rel=1e-8, abs=1e-10 * np.abs(ref).max())


def test_session_stats_are_the_lag_window_normal_equations_of_the_session_alone(study) -> None:
    # formed by hand: the mean-removed traces on the session's own grid (here its own samples,
    # 50 Hz), the lag matrix written out column by column (edge-padded), then W'W and W'y
    from psmat.study import session_stats

    rows, traces = study
    tr = traces[("V02", "right-leg")]
    got = session_stats(tr)
    half = 5  # ±0.1 s at 50 Hz
    assert float(got["rate_hz"]) == pytest.approx(FS, rel=1e-12)
    for k in range(2):
        x, y = _centred(tr["SCHC"])[:, k], _centred(tr["FP"])[:, k]
        W = np.column_stack([np.pad(x, half, mode="edge")[j:j + len(x)] for j in range(2 * half + 1)])
        assert got["gram"][k] == pytest.approx(W.T @ W, rel=1e-9)
        assert got["rhs"][k] == pytest.approx(W.T @ y, rel=1e-9, abs=1e-9 * np.abs(W.T @ y).max())
    assert session_stats({"t_s": tr["t_s"], "FP": tr["FP"]}) == {}  # no SCHC trace: nothing to form


def test_stats_formed_beforehand_give_the_same_rows_bit_for_bit(study) -> None:
    from psmat.study import session_stats

    rows, traces = study
    plain, plain_tr = dynamic_rows(rows, traces)
    given, given_tr = dynamic_rows(rows, traces, stats={k: session_stats(t) for k, t in traces.items()})
    assert _same_nan(given, plain) and all(r["status"] == "ok" for r in given)
    for key in plain_tr:
        assert np.array_equal(given_tr[key]["SCHC-DYN"], plain_tr[key]["SCHC-DYN"])


def _same_nan(a: list[dict], b: list[dict]) -> bool:
    """Rows equal value for value, bit for bit (NaN where both hold NaN)."""
    def same(u, v) -> bool:
        return (isinstance(u, float) and isinstance(v, float) and np.isnan(u) and np.isnan(v)) or u == v

    return len(a) == len(b) and all(r.keys() == s.keys() and all(same(r[c], s[c]) for c in r) for r, s in zip(a, b))


def test_stats_are_used_only_at_the_fitting_rate(study) -> None:
    # statistics that are not the session's: used (the rows change) when they claim the fitting
    # rate, ignored (the rows are those without them) when they claim another rate
    from psmat.study import session_stats

    rows, traces = study
    plain, _ = dynamic_rows(rows, traces)
    wrong = {k: {**session_stats(t), "rhs": -session_stats(t)["rhs"]} for k, t in traces.items()}
    flipped, _ = dynamic_rows(rows, traces, stats=wrong)
    assert all(f["eu_cm"] > p["eu_cm"] for f, p in zip(flipped, plain))  # a sign-flipped correction
    elsewhere = {k: {**v, "rate_hz": np.array(2 * FS)} for k, v in wrong.items()}
    ignored, _ = dynamic_rows(rows, traces, stats=elsewhere)
    assert _same_nan(ignored, plain)
