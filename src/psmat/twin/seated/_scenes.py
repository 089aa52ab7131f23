"""Seated pressure scenes (docs/spec.md §8): the cushion's load shared between the ischial tuberosities,
the thighs and the sacrum (:mod:`psmat.twin.seated._seat`), steered like the standing scenes of
:mod:`psmat.twin.scenes`.

* :func:`seat_scene` — a seat layout loaded by a given force and CoP target over time (the seated
  twin, :mod:`psmat.twin.seated`, drives it from a posture trajectory).
* :func:`sitting` — a person sitting on the mat and leaning slowly (the twin's ``"sitting"`` scene).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._checks import fraction, pair, positive
from ..field import mat_centre_cm
from ..scenes import PressureScene, scene_args
from ._seat import SeatLayout, render_seat, seat_layout, share_load

__all__ = ["seat_scene", "sitting"]


def seat_scene(
    scene: str,
    layout: SeatLayout,
    t: NDArray[np.float64],
    force_n: NDArray[np.float64],
    cop_seat_cm: NDArray[np.float64],
    contact_cm: NDArray[np.float64],
    thigh_share: float,
    shape: tuple[int, int],
    pitch_cm: float,
    supersample: int,
    min_fraction: float,
    extra: dict[str, Any],
) -> PressureScene:
    """A seat's frames (:mod:`psmat.twin.seated._seat`): the load shared for each frame, the cells rendered.

    ``force_n`` (T,) N, ``cop_seat_cm`` (T, 2) the target CoP in the seat frame (u, w) cm,
    ``contact_cm`` (T,) the tuberosities' rolling contact along ``w`` (cm); ``meta`` as the other
    scenes' (``cop_target_cm`` in mat coordinates) plus ``rows`` (T, 3): the ischial, thigh and
    sacral shares.
    """
    load = share_load(layout, force_n, cop_seat_cm, contact_cm, thigh_share, min_fraction)
    pressure, cop_true, on_mat = render_seat(layout, load.weights_n, shape, pitch_cm, supersample)
    clipped = load.clip_cm > 1e-8
    meta: dict[str, Any] = {
        "scene": scene, "shape": shape, "pitch_cm": pitch_cm, "supersample": supersample,
        "groups": [n for n, _ in layout.groups], "group_lobes": [l for _, l in layout.groups],
        "min_fraction": min_fraction, "weights_n": load.weights_n, "rows": load.rows,
        "cop_target_cm": layout.to_mat(np.asarray(cop_seat_cm, dtype=np.float64)), "clipped": clipped,
        "n_clipped": int(clipped.sum()), "clip_cm": np.where(clipped, load.clip_cm, 0.0),
        "force_on_mat_fraction": on_mat, "mat_centre_cm": mat_centre_cm(shape, pitch_cm),
        "seat_origin_cm": layout.origin_cm, "seat_rotation_deg": layout.rotation_deg,
    }
    meta.update(extra)
    return PressureScene(pressure_psi=pressure, t=t, cop_true_cm=cop_true,
                         force_n=np.asarray(force_n, dtype=np.float64).copy(), meta=meta)


def sitting(
    duration_s: float,
    rate_hz: float,
    shape: tuple[int, int] = (16, 16),
    pitch_cm: float = 2.0,
    weight_n: float = 700.0,
    seed: int = 0,
    *,
    seat_fraction: float = 0.75,
    lean_cm: tuple[float, float] = (1.0, 1.5),
    lean_period_s: float = 20.0,
    sway_cm: tuple[float, float] = (0.05, 0.05),
    band_hz: tuple[float, float] = (0.1, 0.5),
    tuberosity_distance_cm: float = 12.0,
    min_fraction: float = 0.02,
    supersample: int = 5,
) -> PressureScene:
    """A person sitting on the mat (the meditation cushion, docs/spec.md §8), the CoP leaning slowly.

    The seat of the seated twin (:func:`~psmat.twin.anatomy.seat_groups`, its load shared by
    :mod:`psmat.twin.seated._seat`) with its tuberosities at ``y = centre − 4 cm``, unrotated,
    symmetric about the mat's vertical midline, the thighs taking 36 % upright. The seat carries
    ``seat_fraction · weight_n``. The CoP leans sinusoidally with amplitudes ``lean_cm``
    (M-L, A-P) and period ``lean_period_s`` (random phases from ``seed``) plus a little
    band-limited sway ``sway_cm``; leaning forward loads the thighs, back the sacrum. For a
    posture (a spine, a protocol, the IMUs) see :mod:`psmat.twin.seated`.

    Parameters
    ----------
    duration_s, rate_hz, shape, pitch_cm, weight_n, seed
        As :func:`quiet_standing` (s, Hz, cells, cm, N, -).
    seat_fraction : float
        Share of the body weight on the seat, in (0, 1].
    lean_cm : (float, float)
        Amplitude of the lean, (M-L, A-P) in cm; (0, 0) with ``sway_cm=(0, 0)`` is still
        and symmetric.
    lean_period_s : float
        Period of the lean in s.
    sway_cm : (float, float)
        Standard deviation of the extra sway in cm.
    band_hz : (float, float)
        Band of the extra sway in Hz.
    tuberosity_distance_cm : float
        Distance between the ischial tuberosities in cm.
    min_fraction : float
        Least share of a left/right pair's load either side keeps.
    supersample : int
        As :func:`quiet_standing`.

    Returns
    -------
    PressureScene
    """
    a = scene_args(duration_s, rate_hz, shape, pitch_cm, weight_n, seed, sway_cm, band_hz, min_fraction, supersample)
    frac = fraction("seat_fraction", seat_fraction)
    if frac == 0:
        raise ValueError("seat_fraction must be > 0")
    lean = pair("lean_cm", lean_cm)
    period = positive("lean_period_s", lean_period_s)
    dist = positive("tuberosity_distance_cm", tuberosity_distance_cm)
    t = a.t
    layout = seat_layout(a.centre - np.array([0.0, 4.0]), 0.0, dist)
    thigh = 0.36
    loc = layout.local_cm
    cop0 = np.array([0.0, (1.0 - thigh) * loc[0:4, 1].mean() + thigh * loc[4, 1]])  # the upright shares' CoP
    rng = a.rng()
    phase = rng.uniform(0.0, 2.0 * np.pi, size=2)
    w = 2.0 * np.pi / period
    target = cop0 + np.column_stack(
        [lean[0] * np.sin(w * t + phase[0]), lean[1] * np.sin(w * t + phase[1])]
    ) + a.sway_noise(rng)
    return seat_scene(
        "sitting", layout, t, np.full(t.size, frac * a.weight), target, np.zeros(t.size), thigh, a.shape, a.pitch,
        a.supersample, a.min_fraction,
        {"rate_hz": a.rate, "seed": a.seed, "weight_n": a.weight, "sway_cm": a.sway, "band_hz": a.band,
         "seat_fraction": frac, "lean_cm": lean, "lean_period_s": period, "lean_phase_rad": phase,
         "tuberosity_distance_cm": dist, "thigh_share": thigh},
    )
