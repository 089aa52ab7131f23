"""Acquisition benchmark (SPEC §10: 165 Hz frames with zero loss over 10 min through the pty twin).

1. psmat: the digital twin (firmware core on a pseudo-terminal) at 165 Hz, v2 frames, read
   by :mod:`psmat.acquire` and recorded to a session file, for ``--seconds`` (600 by
   default). Lost frames are counted by the device's sequence numbers, so the figure is
   measured, not inferred.
2. The same with a corrupted link (bit flips and dropped bytes), psmat against a
   thesis-style reader run in the same process on the same kind of stream: fixed-size v1
   frames read after one initial sync on ``INIT INIT`` (Code 2.1–2.2 on the PC side), bad
   checks stored as missing rows. It never resynchronises, which is what the v1/v2
   decoders' byte-by-byte resync is for.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import threading
import time

import numpy as np

__all__ = ["main"]


def _psmat_run(seconds: float, rate: int, protocol: str, faults: str) -> dict:
    from ..acquire import open_device
    from ..io import SessionWriter, load_session
    from ..twin import Faults, SerialTwin

    path = os.path.join(tempfile.mkdtemp(prefix="psmat-bench-"), "run.h5")
    cpu0 = time.process_time()
    with SerialTwin("psm", rate, protocol, scene="quiet", faults=Faults.parse(faults)) as twin, \
            open_device(twin.port, "psm", protocol) as dev, \
            SessionWriter(path, (16, 16), device=dict(dev.description or {})) as writer:
        dev.record_to(writer)
        dev.start()
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds:
            dev.read(timeout=0.2)
        wall = time.monotonic() - t0
        dev.stop()
        dev.stop_recording()
        st = dev.stats
        sent = twin.stats.frames_sent
    cpu = time.process_time() - cpu0
    s = load_session(path)
    span = int(s.seq[-1] - s.seq[0] + 1) if s.seq is not None else s.n_frames
    return dict(frames=int(s.valid.sum()), invalid=int((~s.valid).sum()), lost=span - s.n_frames, span=span,
                sent=sent, wall=wall, cpu=cpu, buffer_drops=st.dropped_buffer)


def _thesis_reader(port: str, shape: tuple[int, int], stop: threading.Event, out: dict) -> None:
    """The thesis' PC side: sync once on INIT INIT, then fixed-size frames; bad check -> -1 row."""
    import serial

    n = shape[0] * shape[1]
    size = 2 * n + 2
    with serial.Serial(port, timeout=0.2) as s:
        s.reset_input_buffer()
        prev = b""
        while not stop.is_set():  # initial sync
            b = s.read(1)
            if prev == b"\xff" and b == b"\xff":
                break
            prev = b
        good = bad = 0
        while not stop.is_set():
            frame = s.read(size)
            if len(frame) < size:
                continue
            cells = np.frombuffer(frame[:-2], "<u2")
            check = int.from_bytes(frame[-2:], "little")
            if int(cells.sum()) % 4096 == check and cells.max() < 4096:
                good += 1
            else:
                bad += 1
            s.read(2)  # the next INIT INIT, assumed in place
        out.update(frames=good, invalid=bad)


def _thesis_run(seconds: float, rate: int, faults: str) -> dict:
    from ..twin import Faults, SerialTwin

    out: dict = {}
    stop = threading.Event()
    with SerialTwin("psm", rate, "v1", scene="quiet", faults=Faults.parse(faults)) as twin:
        th = threading.Thread(target=_thesis_reader, args=(twin.port, (16, 16), stop, out))
        th.start()
        time.sleep(seconds)
        stop.set()
        th.join(5)
        out["sent"] = twin.stats.frames_sent
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m psmat.bench acquire", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, default=600.0, help="clean-link run (s); SPEC target: 10 min")
    p.add_argument("--fault-seconds", type=float, default=60.0, help="corrupted-link runs (s)")
    p.add_argument("--rate", type=int, default=165)
    p.add_argument("--faults", default="bit_flip=2e-6,drop_byte=2e-6,seed=1")
    args = p.parse_args(argv)
    print(f"acquisition benchmark - {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"Python {sys.version.split()[0]}", flush=True)
    r = _psmat_run(args.seconds, args.rate, "v2", "")
    print(f"clean link, {args.rate} Hz, 16x16 v2, {r['wall']:.0f} s through the pty twin, psmat.acquire + session file:\n"
          f"  frames {r['frames']} valid, {r['invalid']} invalid, {r['lost']} lost (device seq span {r['span']}), "
          f"{r['buffer_drops']} buffer drops; {r['frames'] / r['wall']:.1f} frames/s; "
          f"host CPU {100 * r['cpu'] / r['wall']:.0f} % of one core (twin + reader + writer)", flush=True)
    print(f"corrupted link ({args.faults}), {args.fault_seconds:.0f} s each:", flush=True)
    r = _psmat_run(args.fault_seconds, args.rate, "v2", args.faults)
    print(f"  psmat.acquire, v2      : {r['frames']} valid, {r['invalid']} invalid rows, {r['lost']} lost, "
          f"of {r['sent']} sent", flush=True)
    r = _psmat_run(args.fault_seconds, args.rate, "v1", args.faults)
    print(f"  psmat.acquire, v1      : {r['frames']} valid, {r['invalid']} invalid rows, "
          f"of {r['sent']} sent (v1 cannot count losses)", flush=True)
    b = _thesis_run(args.fault_seconds, args.rate, args.faults)
    print(f"  thesis-style v1 reader : {b.get('frames', 0)} valid, {b.get('invalid', 0)} invalid rows, "
          f"of {b.get('sent', 0)} sent (no resync after the first lost byte)", flush=True)
    return 0
