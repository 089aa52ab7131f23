"""A hang guard for the acquisition tests: a blocking call must return, with no claim on how fast.

A loaded machine (two cores shared with a build) can stretch any wait, so the tests assert
that a wake-up happened (the call returned) under a guard of tens of seconds, never a
duration. The blocked call itself is given a timeout longer than the guard, so a missed
wake-up shows as a hang the guard reports, not as a slow return.
"""

from __future__ import annotations

import threading
from typing import Any, Callable, TypeVar

import pytest

__all__ = ["HANG_GUARD_S", "WAIT_LONGER_S", "returns", "read_until_gone"]

T = TypeVar("T")

#: Seconds a blocking call may take before the test fails as hung (not a performance claim).
HANG_GUARD_S = 30.0
#: A timeout for the guarded call itself (s), longer than the guard: only a wake-up ends it in time.
WAIT_LONGER_S = 600.0


def returns(call: Callable[[], T], what: str, guard_s: float = HANG_GUARD_S) -> T:
    """Run ``call()`` in a daemon thread and fail the test if it has not returned after ``guard_s``.

    Parameters
    ----------
    call : callable
        The blocking call.
    what : str
        What should have ended the wait, for the failure message.
    guard_s : float
        Hang guard (s).

    Returns
    -------
    object
        ``call()``'s result; its exception, if any, is raised here.
    """
    outcome: dict[str, object] = {}

    def run() -> None:
        try:
            outcome["value"] = call()
        except BaseException as exc:  # noqa: BLE001 - handed to the test's thread
            outcome["error"] = exc

    thread = threading.Thread(target=run, name="hang-guard", daemon=True)
    thread.start()
    thread.join(guard_s)
    if thread.is_alive():
        pytest.fail(f"still blocked after the {guard_s:g} s hang guard: {what}")
    if "error" in outcome:
        raise outcome["error"]  # type: ignore[misc]
    return outcome["value"]  # type: ignore[return-value]


def read_until_gone(dev: Any) -> None:
    """Read a :class:`psmat.acquire.Device` until its :class:`DeviceDisconnected` ends the loop.

    Meant to run under :func:`returns`: a device that never reports its loss hangs here.
    """
    while True:
        dev.read(1000, timeout_s=0.5)
