"""Acquisition benchmark (docs/spec.md §10: 165 Hz frames with zero loss over 10 min through the pty twin).

1. psmat: the digital twin (firmware core on a pseudo-terminal) at 165 Hz, v2 frames, read
   by :mod:`psmat.acquire` and recorded to a session file, for ``--seconds`` (600 by
   default). Lost frames are counted by the device's sequence numbers, so the figure is
   measured, not inferred.
2. The same with a corrupted link (bit flips and dropped bytes), psmat against a
   thesis-style reader run in the same process on the same kind of stream. The thesis gives
   the device side (Code 2.1–2.2: ``INIT INIT``, the cells, their sum mod 4096; "if the
   signature is not right, the PC stores -1"); the reader (:mod:`psmat.bench.baselines.thesis_reader`)
   does what that framing allows: before every frame it waits for ``INIT INIT``, then reads the
   frame's fixed size and checks the sum, a bad one stored as a missing row. When a byte is
   lost, that read runs into the next frame's marker, so the next frame leaves no row at all;
   psmat's decoders resync byte by byte after a failed check and find it.
3. The v2 decoder's cost per MiB on valid 16x16 frames, random bytes, and fake headers
   claiming 8 KiB every 18 bytes (docs/protocol.md, "Decoding cost").
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

from .baselines.thesis_reader import thesis_read_port

__all__ = ["main", "build_parser", "thesis_run", "decode_cost"]


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
            dev.read(timeout_s=0.2)
        wall = time.monotonic() - t0
        dev.stop()
        dev.stop_recording()
        st = dev.stats
        sent = twin.stats.frames_sent
        transport = twin.transport  # pty, or tcp where the system has no pty (Windows)
    cpu = time.process_time() - cpu0
    s = load_session(path)
    span = int(s.seq[-1] - s.seq[0] + 1) if s.seq is not None else s.n_frames
    return dict(frames=int(s.valid.sum()), invalid=int((~s.valid).sum()), lost=span - s.n_frames, span=span,
                sent=sent, wall=wall, cpu=cpu, buffer_drops=st.dropped_buffer, transport=transport)


def thesis_run(seconds: float, rate: int, faults: str) -> dict:
    """The thesis-style reader (:mod:`psmat.bench.baselines.thesis_reader`) on the twin's v1 frames.

    Parameters
    ----------
    seconds : float
        How long to read (s).
    rate : int
        The twin's frame rate (frames/s).
    faults : str
        The link's faults (:meth:`psmat.twin.Faults.parse`; ``""`` for none).

    Returns
    -------
    dict
        ``frames`` (valid rows), ``invalid`` (rows with a bad sum) and ``sent`` (frames the twin sent).
    """
    from ..twin import Faults, SerialTwin

    out: dict = {}
    stop = threading.Event()
    with SerialTwin("psm", rate, "v1", scene="quiet", faults=Faults.parse(faults)) as twin:
        th = threading.Thread(target=thesis_read_port, args=(twin.port, (16, 16), stop, out))
        th.start()
        time.sleep(seconds)
        stop.set()
        th.join(5)
        out["sent"] = twin.stats.frames_sent
    return out


def decode_cost(mib: float = 1.0) -> dict[str, tuple[float, float]]:
    """Cost of :class:`~psmat.protocol.V2Decoder` on ``mib`` MiB fed in 4 KiB reads.

    Returns
    -------
    dict
        ``{"valid" | "random" | "fake headers": (seconds per MiB, CRC bytes per input byte)}``
        for valid 16x16 frames, random bytes, and 64x64 headers (8 KiB claimed) every 18 bytes.
    """
    from ..protocol import V2Decoder, encode_v2

    n = int(mib * (1 << 20))
    rng = np.random.default_rng(0)
    frames = b"".join(encode_v2(f, i, 6061 * i) for i, f in enumerate(rng.integers(0, 4096, (n // 530 + 1, 16, 16))))
    fake = encode_v2(np.zeros((64, 64), np.uint16), 0, 0)[:16] + b"\0\0"
    streams = {"valid": frames[:n], "random": rng.integers(0, 256, n, dtype=np.uint8).tobytes(),
               "fake headers": (fake * (n // 18 + 1))[:n]}
    out = {}
    for name, data in streams.items():
        dec = V2Decoder()
        t0 = time.perf_counter()
        for i in range(0, n, 4096):
            dec.feed(data[i:i + 4096])
        dec.finish()
        out[name] = ((time.perf_counter() - t0) * (1 << 20) / n, dec.crc_bytes / n)
    return out


def build_parser(prog: str = "python -m psmat.bench acquire") -> argparse.ArgumentParser:
    """The benchmark's options (its help: this module's docstring, every default and unit)."""
    from .._help import HelpFormatter, plain

    p = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    p.add_argument("--seconds", type=float, default=600.0,
                   help="length of the clean-link run, docs/spec.md §10's target is 10 min (s)")
    p.add_argument("--fault-seconds", type=float, default=60.0,
                   help="length of each corrupted-link run, psmat's and the thesis-style reader's (s)")
    p.add_argument("--rate", type=int, default=165, help="the twin's frame rate (frames/s)")
    p.add_argument("--faults", default="bit_flip=2e-6,drop_byte=2e-6,seed=1",
                   help="the corrupted link's faults: probability per byte of a flipped bit and of a dropped "
                        "byte, and the seed of their draws")
    return p


def main(argv: list[str] | None = None, prog: str = "python -m psmat.bench acquire") -> int:
    args = build_parser(prog).parse_args(argv)
    t_start = time.monotonic()
    print(f"acquisition benchmark - {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"Python {sys.version.split()[0]}", flush=True)
    r = _psmat_run(args.seconds, args.rate, "v2", "")
    print(f"clean link, {args.rate} Hz, 16x16 v2, {r['wall']:.0f} s through the {r['transport']} twin, "
          "psmat.acquire + session file:\n"
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
    b = thesis_run(args.fault_seconds, args.rate, args.faults)
    print(f"  thesis-style v1 reader : {b.get('frames', 0)} valid, {b.get('invalid', 0)} invalid rows, "
          f"of {b.get('sent', 0)} sent (INIT INIT, then a fixed-size read)", flush=True)
    cost = ", ".join(f"{k} {s:.3f} s ({c:.2f})" for k, (s, c) in decode_cost().items())
    print(f"v2 decoder per MiB (CRC bytes per input byte): {cost}", flush=True)
    print(f"wall time of the whole benchmark: {time.monotonic() - t_start:.0f} s", flush=True)
    return 0
