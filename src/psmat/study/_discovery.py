"""What ``psmat study run`` read from each session file's metadata, kept for the next run by the file's
content: a rerun finds its sessions without opening the files it has seen (docs/spec.md §12).

Finding a study's sessions opens every session file through h5py and checks its structure and
metadata (:func:`psmat.study.find_study`): ~13 ms a file, 1.6 s of a thesis-size study's rerun that
computes nothing. A run hashes every session file anyway, for the keys of its results
(:mod:`psmat.study` (``_hashes.py``)); ``results/.discovery.json`` keeps, for each file read, its
name, the SHA-256 of its bytes and what was read (subject, trial, whether a simulator wrote it, the
box serial, the circuit of its description and calibration, whether it stores a calibration). A
later run takes an entry only for a file of that name whose bytes hash the same, read by the same
psmat version, with no journal beside it; any other file is read again.

Only what a clean read gave is kept: a file that could not be read, a recording that was not
closed, a file with a journal beside it or one written to after its hash started (until the record
is written: :meth:`psmat.study._hashes.FileHashes.unchanged`) is read again next run. The record
proves itself as the session results do (``digest``, :mod:`psmat.study` (``_cache.py``)): one of
another psmat version is not used; one larger than :data:`MAX_BYTES`, that does not parse, or that
fails its digest or the checks of an entry is not used either, and the run says why among its
problems; both are rewritten. As there, the digest detects corruption and edits, not forgery:
whoever can write ``results/`` can also write ``metrics.csv``. A record that cannot be written is a
problem line of the run, not its end.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ._cache import canonical_json, write_text_atomic
from ._hashes import FileHashes
from ._layout import SessionMeta
from ._plain import digest, parse_json

__all__ = ["NAME", "SCHEMA", "MAX_BYTES", "DiscoveryRecord"]

NAME = ".discovery.json"
#: a record larger than this is not read (~330 bytes a session: room for 100 000 sessions)
MAX_BYTES = 64 << 20
SCHEMA = "psmat-study-discovery/1"
_FIELDS = frozenset({"schema", "psmat", "entries", "digest"})
_ENTRY = frozenset({"sha256", "subject", "trial", "simulated", "serial", "circuit", "uncalibrated"})
_SHA = re.compile(r"[0-9a-f]{64}")
_CIRCUIT = frozenset({"r_o_ohm", "r_mux_ohm", "r_adc_ohm", "v_ref_volt", "bits", "sensor_side"})


class DiscoveryRecord:
    """``results/.discovery.json`` of one study (module docstring).

    Parameters
    ----------
    results : path
        The study's ``results/`` folder (it may not exist yet).
    version : str
        This psmat's version: a record of another is not used.
    """

    def __init__(self, results: Path, version: str) -> None:
        self.path = Path(results) / NAME
        self.version = version
        #: why the record on disk is not used (one line), or None (used, or none there)
        self.problem: str | None = None
        self._entries: dict[str, dict[str, Any]] = {}
        self._circuits: dict[str, Any] = {}  # each entry's circuit, made once when the record is checked
        self._journalled: set[str] | None = None
        self._used: set[str] = set()
        try:
            with open(self.path, "rb") as fh:
                text = fh.read(MAX_BYTES + 1)
        except FileNotFoundError:
            return
        except OSError as exc:
            self.problem = f"{self.path} not used ({exc.strerror or exc}); every session's metadata read again"
            return
        if len(text) > MAX_BYTES:
            self.problem = (f"{self.path} not used (larger than {MAX_BYTES} bytes, which no record of a study "
                            "is); every session's metadata read again")
            return
        try:
            self._entries, self._circuits = _parse(text, version)
        except _Stale:
            return
        except ValueError as exc:
            self.problem = f"{self.path} not used ({exc}); every session's metadata read again"

    def known(self, path: Path, hashes: FileHashes) -> SessionMeta | None:
        """What an earlier run read from the session file ``path`` when it was these bytes, else None."""
        e = self._entries.get(path.name)
        if e is None:
            return None
        if self._journalled is None:  # the folder listed once, not once a session
            self._journalled = _journalled(path.parent)
        if path.name in self._journalled or hashes.sha(path) != e["sha256"]:
            return None
        self._used.add(path.name)
        return (e["subject"], e["trial"], None, e["simulated"], None, e["serial"], self._circuits[path.name],
                e["uncalibrated"])

    def write(self, read: Mapping[Path, SessionMeta], hashes: FileHashes) -> bool:
        """Keep the entries used this run and those of the files read cleanly (module docstring); write
        the record atomically when that changes it. Returns whether it was written.

        Raises
        ------
        OSError
            The record could not be written (the one on disk, if any, is left whole).
        """
        entries = {name: self._entries[name] for name in self._used}
        journalled: dict[Path, set[str]] = {}  # each folder listed once, now
        for path, (subject, trial, problem, simulated, not_closed, serial, circuit, uncalibrated) in read.items():
            if path.parent not in journalled:
                journalled[path.parent] = _journalled(path.parent)
            if problem is not None or not_closed is not None or path.name in journalled[path.parent] \
                    or not hashes.unchanged(path):
                continue
            sha = hashes.sha(path)
            if sha is None:
                continue
            entries[path.name] = {"sha256": sha, "subject": subject, "trial": trial, "simulated": bool(simulated),
                                  "serial": serial, "circuit": None if circuit is None else _circuit_doc(circuit),
                                  "uncalibrated": bool(uncalibrated)}
        if entries == self._entries and self.problem is None:
            return False
        doc: dict[str, Any] = {"schema": SCHEMA, "psmat": self.version, "entries": entries}
        doc["digest"] = digest(canonical_json(doc))
        write_text_atomic(self.path, canonical_json(doc))
        self._entries, self.problem = entries, None
        return True


def _journalled(folder: Path) -> set[str]:
    """The names of the session files of ``folder`` that a journal lies beside: its own
    (``NAME.h5.journal``), a stream's (``NAME.h5.STREAM.journal``) or anything named like one (such a
    file is read again rather than taken from the record). Every ``….h5`` that a journal's name starts
    with counts, so that a doubtful name costs a read, never a stale entry."""
    names: set[str] = set()
    try:
        journals = [p.name for p in folder.iterdir() if p.name.endswith(".journal")]
    except OSError:
        return names
    for j in journals:
        stem = j[: -len(".journal")]
        at = stem.find(".h5")
        while at >= 0:
            if at + 3 == len(stem) or stem[at + 3] == ".":
                names.add(stem[: at + 3])
            at = stem.find(".h5", at + 1)
    return names


class _Stale(Exception):
    """A record of another psmat version or schema: not used, quietly."""


def _parse(text: bytes, version: str) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """The entries of a record, and each one's circuit; ValueError (why) or _Stale."""
    doc = parse_json(text)
    if not isinstance(doc, dict) or set(doc) != _FIELDS:
        raise ValueError("not a discovery record")
    if doc["schema"] != SCHEMA or doc["psmat"] != version:
        raise _Stale
    body = {k: v for k, v in doc.items() if k != "digest"}
    if doc["digest"] != digest(canonical_json(body)):
        raise ValueError("its digest does not match: edited or damaged")
    entries = doc["entries"]
    if not isinstance(entries, dict):
        raise ValueError("its entries are not a table")
    circuits = {}
    for name, e in entries.items():
        try:
            circuits[name] = _checked_entry(name, e)
        except ValueError as exc:
            raise ValueError(f"entry {name!r}: {exc}") from None
    return entries, circuits


def _checked_entry(name: str, e: Any) -> Any:
    """The circuit of the entry ``e`` of the session file ``name`` (None for none); ValueError (why) if
    the entry is not one a run writes."""
    if not name.endswith(".h5") or "/" in name or "\\" in name or name.startswith("."):
        raise ValueError("not a session file's name")
    if not isinstance(e, dict) or set(e) != _ENTRY:
        raise ValueError("not an entry")
    if not isinstance(e["sha256"], str) or not _SHA.fullmatch(e["sha256"]):
        raise ValueError("no SHA-256")
    if any(e[k] is not None and not isinstance(e[k], str) for k in ("subject", "trial", "serial")):
        raise ValueError("subject, trial and serial are text or null")
    if not isinstance(e["simulated"], bool) or not isinstance(e["uncalibrated"], bool):
        raise ValueError("simulated and uncalibrated are true or false")
    try:
        return _circuit(e["circuit"])
    except (TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"not a circuit ({exc})") from None


def _circuit_doc(c: Any) -> dict[str, Any]:
    d = dict(c.as_dict())
    if math.isinf(d["r_adc_ohm"]):
        d["r_adc_ohm"] = None  # an ideal ADC (JSON has no infinity)
    return d


def _circuit(d: Any) -> Any:
    """The circuit of :func:`_circuit_doc`'s ``d`` (None for None); TypeError, ValueError otherwise."""
    if d is None:
        return None
    from ..circuit import Circuit

    if not isinstance(d, dict) or set(d) != _CIRCUIT:
        raise ValueError("not the constants of a circuit")
    if isinstance(d["bits"], bool) or not isinstance(d["bits"], int):
        raise ValueError("bits is not an integer")
    r_adc = math.inf if d["r_adc_ohm"] is None else d["r_adc_ohm"]
    return Circuit(r_o=d["r_o_ohm"], r_mux=d["r_mux_ohm"], r_adc=r_adc, v_ref=d["v_ref_volt"], bits=d["bits"],
                   sensor_side=d["sensor_side"])
