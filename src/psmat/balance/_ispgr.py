"""The ISPGR acquisition recommendation for a sway trial (Scoppa et al. 2013; docs/spec.md §7):
at least 25 s, sampled at 50 Hz or more. One check, used by the study's rows and the report."""

from __future__ import annotations

__all__ = ["ISPGR_MIN_S", "ISPGR_MIN_HZ", "ISPGR_RATE_RTOL", "ispgr"]

#: ISPGR (Scoppa et al. 2013): shortest recording (s) and lowest sample rate (Hz)
ISPGR_MIN_S = 25.0
ISPGR_MIN_HZ = 50.0
#: a rate this close below the minimum still meets it (a device clock's drift: 49.999 Hz is a 50 Hz mat)
ISPGR_RATE_RTOL = 1e-3


def ispgr(duration_s: float, rate_hz: float, min_duration_s: float = ISPGR_MIN_S,
          min_rate_hz: float = ISPGR_MIN_HZ) -> str:
    """``"ok"``, or why a trial of ``duration_s`` (s) sampled at ``rate_hz`` (Hz) misses the ISPGR
    recommendation, the reasons joined by ``"; "``: e.g. ``"short: 20.0 s < 25 s; rate 40 Hz < 50 Hz"``.

    A rate within :data:`ISPGR_RATE_RTOL` (0.1 %) below ``min_rate_hz`` meets it; a NaN fails both.
    """
    why = []
    if not duration_s >= min_duration_s:
        why.append(f"short: {duration_s:.1f} s < {min_duration_s:g} s")
    if not rate_hz >= min_rate_hz * (1.0 - ISPGR_RATE_RTOL):
        why.append(f"rate {rate_hz:.6g} Hz < {min_rate_hz:g} Hz")
    return "; ".join(why) or "ok"
