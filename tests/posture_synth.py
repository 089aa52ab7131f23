"""Tiny synthetic posture recordings for the learning tests: a known, learnable relation.

Five smooth pitch traces drive the image: a seat blob plus, for each sensor k, a blob of its
own at its own place whose amplitude is linear in that sensor's angle. The window-mean image is
then exactly linear in the window-mean angles (what the ridge-PCA test relies on).
"""

from __future__ import annotations

import numpy as np

from psmat.posture import Recording

RATE_HZ = 10.0


def patterns(R: int, C: int) -> np.ndarray:
    """(6, R, C): the seat blob and one blob per sensor, unit peak."""
    rr, cc = np.mgrid[0:R, 0:C]
    centres = [(R / 2, C / 2), (1, 1), (1, C - 2), (R - 2, 1), (R - 2, C - 2), (R / 2, 1)]
    return np.stack([np.exp(-((rr - r) ** 2 + (cc - c) ** 2) / (2 * (R / 6) ** 2)) for r, c in centres])


def angles(T: int, rng: np.random.Generator) -> np.ndarray:
    """(T, 5) smooth angles (rad), sums of slow sinusoids of random phase, within ±0.4."""
    t = np.arange(T) / RATE_HZ
    f = rng.uniform(0.02, 0.1, size=(3, 5))
    ph = rng.uniform(0, 2 * np.pi, size=(3, 5))
    return 0.4 / 3 * np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).sum(axis=1)


def recording(subject: str, day: int, T: int, R: int = 8, C: int = 8, *, seed: int = 0,
              noise: float = 0.0) -> Recording:
    """One recording; image (S-like units) = seat + Σ_k (0.5 + angle_k) · blob_k (+ noise)."""
    rng = np.random.default_rng(seed)
    a = angles(T, rng)
    p = patterns(R, C)
    img = p[0][None] + np.einsum("tk,krc->trc", 0.5 + a, p[1:])
    img = img + noise * rng.standard_normal(img.shape)
    return Recording(subject, day, np.arange(T) / RATE_HZ, (1e-3 * img).astype(np.float32), a,
                     meta={"simulated": True})


def study(n_subjects: int = 4, days: int = 1, T: int = 400, R: int = 8, C: int = 8, *, seed: int = 0,
          noise: float = 0.0) -> list[Recording]:
    """Recordings P01.. with ``days`` each."""
    return [recording(f"P{s + 1:02d}", d + 1, T, R, C, seed=seed * 1000 + s * 10 + d, noise=noise)
            for s in range(n_subjects) for d in range(days)]
