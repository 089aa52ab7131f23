"""The lab's walk-through of the box's electronics calibration (docs/spec.md §2 "Calibration").

The steps are those of ``psmat calibrate`` (:mod:`psmat.workflows.calibrate_steps`): the mat
unplugged (every cell open: ``R_adc``), then one row wired to one column for each pair of a
list (``R_mux``; default the four corners, as ``psmat calibrate --pairs corners``). The page
asks the person for each set-up and the server records it from the live device while the
display keeps running:

* a step taps the device's reader thread (:meth:`psmat.acquire.Device.record_to` with a
  collector instead of a session writer), so the display feed, which drains the device's ring
  buffer, and the step each get every frame; a v2 box is held on the wired pair (CAL_HOLD)
  during a short step, as ``psmat calibrate`` does;
* with the digital twin (``psmat lab --simulate``) ``set_fixture`` switches its
  :class:`psmat.twin.CalibrationFixture` to the step's set-up (``"open"``,
  ``("short", row, col)``; ``"mat"`` again at the end), so no person is needed;
* :meth:`CalibrationWalk.estimate` hands the recorded steps to
  :func:`psmat.workflows.calibrate_steps.run_calibration` (through :class:`_RecordedSteps`, a
  device that plays the recorded frames back), so R_adc and R_mux come out of the very code
  ``psmat calibrate`` runs.

Counts are ADC counts; durations are seconds.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._errors import LabConflict

__all__ = ["CalibrationWalk", "parse_pairs", "step_diagnostics"]

#: frame periods waited after a set-up change before frames count (those scanned before it are on the way)
_SETTLE_FRAMES = 3
#: longest step (s)
_MAX_SECONDS = 10.0


def parse_pairs(spec: Any, shape: tuple[int, int]) -> list[tuple[int, int]]:
    """The row-column pairs to short: ``"corners"`` (default), ``"all"``, ``"i,p;i,p"`` or a list
    of ``[i, p]`` (0-based logical row and column), each inside the ``shape`` array."""
    R, C = shape
    if spec is None or spec == "corners":
        return sorted({(0, 0), (0, C - 1), (R - 1, 0), (R - 1, C - 1)})
    if spec == "all":
        return [(i, p) for i in range(R) for p in range(C)]
    try:
        if isinstance(spec, str):
            items = [tuple(int(v) for v in item.split(",")) for item in spec.split(";") if item.strip()]
        else:
            items = [tuple(int(v) for v in item) for item in spec]
    except (TypeError, ValueError):
        raise ValueError(f"pairs must be 'corners', 'all', 'i,p;i,p' or [[i, p], ...], got {spec!r}") from None
    pairs: list[tuple[int, int]] = []
    for item in items:
        if len(item) != 2 or not (0 <= item[0] < R and 0 <= item[1] < C):
            raise ValueError(f"pair {list(item)} is not a (row, column) of the {R}x{C} mat")
        if item not in pairs:
            pairs.append((item[0], item[1]))
    if not pairs:
        raise ValueError("pairs is empty: give at least one row-column pair to short")
    return pairs


def step_diagnostics(samples: NDArray[Any], full_scale: int, frames: int) -> dict[str, Any]:
    """What the page shows for a recorded step: ``frames``, the ``samples`` the estimate uses,
    their ``mean_count`` and ``spread_count`` (standard deviation, counts) and the
    ``clipped_fraction`` of samples at 0 or at the ADC's full scale (a wire that is not in
    place, or an open circuit beyond the ADC's resolution, read there)."""
    x = np.asarray(samples, dtype=np.float64).ravel()
    return {"frames": int(frames), "samples": int(x.size), "mean_count": float(x.mean()),
            "spread_count": float(x.std()), "clipped_fraction": float(np.mean((x <= 0) | (x >= full_scale))),
            "full_scale": int(full_scale)}


class _StepTap:
    """Collects the valid frames a device's reader thread hands over (the ``append`` /
    ``set_counters`` interface of a session writer) until ``n`` have arrived."""

    def __init__(self, n: int) -> None:
        self.n = int(n)
        self._parts: list[NDArray[Any]] = []
        self._count = 0
        self._lock = threading.Lock()
        self.full = threading.Event()

    def append(self, frames: NDArray[Any], host_time_s: Any, valid: NDArray[np.bool_], seq: Any,
               device_time_us: Any) -> None:
        with self._lock:
            if self._count >= self.n:
                return
            good = np.asarray(frames)[np.asarray(valid, dtype=bool)][: self.n - self._count]
            if len(good):
                self._parts.append(good.copy())
                self._count += len(good)
            if self._count >= self.n:
                self.full.set()

    def set_counters(self, **counters: Any) -> None:
        """A step has no counters to keep."""

    def frames(self, shape: tuple[int, int]) -> NDArray[Any]:
        with self._lock:
            return np.concatenate(self._parts) if self._parts else np.empty((0, *shape), np.uint16)


class _RecordedSteps:
    """A device that plays the recorded steps back to :func:`run_calibration`: each ``read``
    with ``n`` (a step's recording) returns the next step's frames, a ``read`` without one (the
    frames measured before the set-up changed, dropped) returns none; CAL_HOLD was applied live."""

    def __init__(self, shape: tuple[int, int], protocol: Any, description: dict[str, Any],
                 steps: Sequence[NDArray[Any]]) -> None:
        self.shape, self.protocol, self.description = tuple(shape), protocol, description
        self._steps = list(steps)

    def read(self, n: int | None = None, timeout_s: float | None = None) -> Any:
        frames = self._steps.pop(0) if n is not None else np.empty((0, *self.shape), np.uint16)
        return SimpleNamespace(frames=frames, valid=np.ones(len(frames), dtype=bool))

    def cal_hold(self, row: int, col: int) -> None:
        """Already done while the step was recorded."""

    def cal_resume(self) -> None:
        """Already done while the step was recorded."""


class CalibrationWalk:
    """One calibration walk-through on a started live device.

    Parameters
    ----------
    device : psmat.acquire.Device
        The box, started (its reader thread runs).
    profile : psmat.Profile
        The box's profile: its circuit (R_o, V_ref, bits; the nominal R_adc) and frame rate.
    pairs : list of (int, int)
        The row-column pairs to short, in the order asked.
    seconds : float
        Recording length of each step (s).
    set_fixture : callable, optional
        The twin's set-up switch (``"open"``, ``("short", i, p)``, ``"mat"``); None for a real box.
    """

    def __init__(self, device: Any, profile: Any, pairs: Sequence[tuple[int, int]], seconds: float = 1.0,
                 set_fixture: Callable[[Any], None] | None = None) -> None:
        if not (isinstance(seconds, (int, float)) and not isinstance(seconds, bool) and 0.1 <= seconds <= _MAX_SECONDS):
            raise ValueError(f"seconds must be a number from 0.1 to {_MAX_SECONDS:g}, got {seconds!r}")
        self.device, self.profile = device, profile
        self.shape = tuple(int(x) for x in device.shape)
        self.pairs = list(pairs)
        self.seconds = float(seconds)
        self.set_fixture = set_fixture
        self.circuit = profile.circuit()
        self.hold = device.protocol == 2
        self.recorded: dict[Any, NDArray[Any]] = {}      # "open" or (i, p) -> frames
        self.diagnostics: dict[str, dict[str, Any]] = {}
        self.busy = False
        self._step_lock = threading.Lock()
        self.cancelled = threading.Event()

    @property
    def rate_hz(self) -> float:
        return float((self.device.description or {}).get("rate") or self.profile.rate_hz or 100.0)

    def steps(self) -> list[dict[str, Any]]:
        """The steps to show: ``{"step", "row"?, "col"?, "key", "instruction", "done", "diagnostics"}``."""
        sim = " (the simulated box sets this up itself)" if self.set_fixture is not None else ""
        out = [{"step": "open", "key": "open", "done": "open" in self.recorded,
                "instruction": f"Unplug the mat from the box, then press Record step{sim}.",
                "diagnostics": self.diagnostics.get("open")}]
        for k, (i, p) in enumerate(self.pairs):
            key = f"short {i},{p}"
            out.append({"step": "short", "row": i, "col": p, "key": key, "done": (i, p) in self.recorded,
                        "instruction": f"Wire row {i} to column {p} with a wire (short {k + 1} of {len(self.pairs)}), "
                                       f"then press Record step{sim}.", "diagnostics": self.diagnostics.get(key)})
        return out

    def state(self) -> dict[str, Any]:
        """``GET /api/status``'s ``calibration`` and what ``start`` / ``step`` return."""
        return {"active": True, "pairs": [list(x) for x in self.pairs], "seconds": self.seconds,
                "simulated": self.set_fixture is not None, "busy": self.busy, "steps": self.steps(),
                "ready": "open" in self.recorded and any(k != "open" for k in self.recorded)}

    def record(self, step: str, row: Any = None, col: Any = None) -> dict[str, Any]:
        """Record one step (blocks about ``seconds``): the set-up changed (the twin's), the box
        held on the pair (v2), the frames collected; its diagnostics."""
        if step == "open":
            key: Any = "open"
            mode: Any = "open"
        elif step == "short":
            if isinstance(row, bool) or isinstance(col, bool) or not isinstance(row, int) or not isinstance(col, int):
                raise ValueError("a short step needs integer \"row\" and \"col\"")
            if (row, col) not in self.pairs:
                raise ValueError(f"({row}, {col}) is not one of the pairs of this calibration: {self.pairs}")
            key, mode = (row, col), ("short", row, col)
        else:
            raise ValueError(f"step must be \"open\" or \"short\", got {step!r}")
        if not getattr(self.device, "connected", True):
            raise LabConflict("the box is disconnected")
        if not self._step_lock.acquire(blocking=False):
            raise LabConflict("a calibration step is being recorded: wait for it")
        self.busy = True
        try:
            if self.set_fixture is not None:
                self.set_fixture(mode)
            held = self.hold and step == "short"
            if held:
                self.device.cal_hold(row, col)
            try:
                frames = self._collect()
            finally:
                if held:
                    self.device.cal_resume()
        finally:
            self.busy = False
            self._step_lock.release()
        if self.cancelled.is_set():
            raise LabConflict("the calibration was cancelled")
        if len(frames) == 0:
            raise LabConflict("no valid frames arrived during this step; is the box streaming?")
        self.recorded[key] = frames
        samples = frames if step == "open" or self.hold else frames[:, row, col]
        name = "open" if step == "open" else f"short {row},{col}"
        self.diagnostics[name] = diag = step_diagnostics(samples, self.circuit.full_scale, len(frames))
        return {"step": step, "row": row, "col": col, "key": name, "diagnostics": diag, "calibration": self.state()}

    def _collect(self) -> NDArray[Any]:
        """``seconds`` of valid frames from the reader thread, once the frames scanned before the
        set-up changed have gone by."""
        rate = self.rate_hz
        tap = _StepTap(max(2, int(self.seconds * rate)))
        if self.cancelled.wait(_SETTLE_FRAMES / rate):
            return tap.frames(self.shape)
        self.device.record_to(tap)
        try:
            t_end = time.monotonic() + self.seconds + 2.0
            while not tap.full.is_set() and not self.cancelled.is_set() and time.monotonic() < t_end:
                tap.full.wait(0.05)
        finally:
            self.device.stop_recording()
        return tap.frames(self.shape)

    def estimate(self, log: Callable[[str], Any]) -> Any:
        """The :class:`psmat.Calibration` of the recorded steps, by ``psmat calibrate``'s own
        :func:`run_calibration` (the shorted pairs in the order asked; those not recorded left out)."""
        from ..workflows.calibrate_steps import run_calibration

        pairs = [x for x in self.pairs if x in self.recorded]
        desc = {"serial": (self.device.description or {}).get("serial", ""), "rate": self.rate_hz}
        played = _RecordedSteps(self.shape, self.device.protocol, desc,
                                [self.recorded["open"], *(self.recorded[x] for x in pairs)])
        return run_calibration(played, pairs, seconds=self.seconds, prompt=lambda text: None, set_fixture=None,
                               circuit=self.circuit, log=log, rate_hz=self.rate_hz)

    def cancel(self) -> None:
        """Stop a step being recorded (it returns with a conflict) and put the twin's mat back."""
        self.cancelled.set()
        self.reset_fixture()

    def reset_fixture(self) -> None:
        if self.set_fixture is not None:
            self.set_fixture("mat")
