"""The profile a recorded session was made with (docs/spec.md §5 "Device profiles", §6)."""

from __future__ import annotations

import math
from typing import Any

from ._errors import ProfileError
from ._geometry import Geometry
from ._load import default_profile, load_profile
from ._profile import Profile

__all__ = ["session_profile"]

#: The name of a profile rebuilt from an older file's device record.
DEVICE_RECORD = "session-device"


def _number(value: Any, default: Any) -> Any:
    ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value) and value > 0
    return value if ok else default


def session_profile(session: Any) -> Profile:
    """The profile of a loaded session.

    Parameters
    ----------
    session : psmat.io.Session
        A loaded session (anything with ``kind``, ``device``, ``frame_shape`` and, in files that
        store one, ``profile``: the dict of :meth:`Profile.to_dict`).

    Returns
    -------
    Profile
        The stored profile; for a file without one (written before sessions stored profiles), a
        mat's profile rebuilt from the session: its frame shape, the device record's ``pitch_cm``,
        ``r_o``, ``v_ref``, ``bits``, ``rate`` and ``proto`` where it has them, the rest (pitch,
        origin, axes, R_mux, R_adc) the default profile's (:data:`DEFAULT_PROFILE`); for an IMU or
        DAQ session, the shipped ``imu`` or ``daq`` profile. Never fails for a mat session without
        a stored profile.

    Raises
    ------
    ProfileError
        A stored profile with a bad key, or a session of an unknown kind without one.
    """
    stored = getattr(session, "profile", None)
    where = f"{getattr(session, 'path', None) or 'session'}: stored profile"
    if stored:
        return Profile.from_dict(stored, where=where)
    kind = getattr(session, "kind", None)
    if kind in ("imu", "daq"):
        return load_profile(kind)
    if kind != "psm":
        raise ProfileError(f"{where}: none, and a {kind!r} session has no shipped profile")
    base = default_profile()
    assert base.geometry is not None and base.r_o_ohm is not None
    device = getattr(session, "device", None) or {}
    shape = tuple(int(n) for n in session.frame_shape)
    pitch = float(_number(device.get("pitch_cm"), base.geometry.pitch_cm))
    geometry = Geometry(shape, pitch, base.geometry.origin_cm, base.geometry.x,  # type: ignore[arg-type]
                        base.geometry.y)
    bits = device.get("bits")
    proto = device.get("proto")
    return Profile(
        name=DEVICE_RECORD,
        description=f"a {shape[0]}x{shape[1]} mat rebuilt from the session's device record (no stored profile)",
        kind="psm", protocol={1: "v1", 2: "v2"}.get(proto, base.protocol) if not isinstance(proto, bool) else
        base.protocol, rate_hz=float(_number(device.get("rate"), base.rate_hz)), baudrate=base.baudrate,
        shape=shape, pitch_cm=pitch, geometry=geometry,
        r_o_ohm=float(_number(device.get("r_o"), base.r_o_ohm)),
        v_ref_volt=float(_number(device.get("v_ref"), base.v_ref_volt)),
        bits=bits if isinstance(bits, int) and not isinstance(bits, bool) and 1 <= bits <= 16 else base.bits,
        r_mux_ohm=base.r_mux_ohm, r_adc_ohm=base.r_adc_ohm,
        source=f"{getattr(session, 'path', None) or 'session'}: device record (no stored profile)")
