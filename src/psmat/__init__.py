"""psmat - software for low-cost pressure-sensitive mats (Velostat resistive sensor arrays).

Submodules: :mod:`psmat.iecm` (crosstalk removal), :class:`psmat.Circuit` (measurement
chain counts <-> conductance), :class:`psmat.Calibration` (a box's R_adc and R_mux, as data;
:mod:`psmat.circuit` also has their estimates from open/short-circuit recordings),
:mod:`psmat.noise` (Table 2.4 noise model), :mod:`psmat.sensor` (Velostat hysteresis +
creep), :mod:`psmat.protocol` (wire formats), :mod:`psmat.io` (session files, force
platforms), :mod:`psmat.twin` (the simulated mat: the one synthetic world of tests,
benchmarks and demos), :mod:`psmat.acquire` (reading devices over serial),
:mod:`psmat.process` (counts → pressure → CoP), :mod:`psmat.profile` (devices as data: :class:`psmat.Profile`,
:func:`psmat.load_profile`), :mod:`psmat.qzpm` (IECM for the QZPM readout, App. C),
:mod:`psmat.experiments` (the thesis' crosstalk studies), :mod:`psmat.balance` (sway, alignment,
the chapter 3 variants), :mod:`psmat.study` (a balance study folder run in batch), :mod:`psmat.spine`
and :mod:`psmat.posture` (the spine's shape, learning it from the cushion) and :mod:`psmat.synth`
(simulated studies through the twin).
"""

from __future__ import annotations

import importlib

from ._version import __version__  # the one place the version is written

# ``import psmat`` loads nothing else: each subpackage is imported the first time it is used
# (``psmat.iecm``, ``from psmat import io``), by :func:`__getattr__` (PEP 562), so a command
# line or a script pays only for what it touches (docs/architecture.md, "Import cost").
#: The subpackages and modules reachable as ``psmat.NAME`` without importing them first.
_SUBMODULES = frozenset({
    "acquire", "balance", "circuit", "experiments", "frames", "iecm",
    "io", "noise", "posture", "pressure", "process", "profile", "protocol", "qzpm", "regions", "sensor", "spine",
    "study", "synth", "twin", "units",
})
#: Classes (and a function) reachable as ``psmat.NAME``, and the module each lives in.
_CLASSES = {"Calibration": "circuit", "Circuit": "circuit", "Profile": "profile", "load_profile": "profile"}

__all__ = ["acquire", "balance", "circuit", "experiments", "iecm", "io", "noise", "posture", "pressure",
           "process", "profile", "protocol", "qzpm", "regions", "sensor", "spine", "study", "synth", "twin", "Circuit",
           "Calibration", "Profile", "load_profile", "__version__"]

TYPE_CHECKING = False
if TYPE_CHECKING:  # what static checkers and editors see; at run time __getattr__ below imports these
    from . import (acquire, balance, circuit, experiments, frames, iecm, io, noise, posture, pressure,
                   process, profile, protocol, qzpm, regions, sensor, spine, study, synth, twin, units)
    from .circuit import Calibration, Circuit
    from .profile import Profile, load_profile


def __getattr__(name: str) -> object:
    """``psmat.NAME`` for a subpackage or class not imported yet: import it now (PEP 562)."""
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")  # also binds psmat.NAME
    if name in _CLASSES:
        value = getattr(importlib.import_module(f"{__name__}.{_CLASSES[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | _SUBMODULES)
