"""The lab page in a browser beside the matplotlib view, on the simulated mat at 100 and 165 Hz.

For each rate, two displays of the same digital twin (the psm16 profile, 16 x 16 cells,
protocol v2 over a pseudo-terminal, the swaying-person scene), one after the other:

* **lab page**: ``psmat lab --simulate`` (the server in a child process, recording the trial
  while it feeds the page) and its page in headless Chromium, driven over the DevTools
  protocol (:mod:`psmat.bench.chromium`). Measured over ``--seconds`` after ``--warmup``:
  frames the page drew per second (``window.psmatLab.framesDrawn``); the latency from each
  frame message's device time to its arrival in the page (median and 95th percentile), the
  page mapping the device clock onto the host's wall clock by the least-delayed frame (the
  smallest host time minus device time so far), so that it counts the delay beyond the
  fastest frame's link transit: reading, the wait for the next display update, processing,
  the WebSocket, the page's event loop; the time from the server receiving a frame to the
  page drawing it (``lastLatencyMs``, sampled every ``--poll`` s); the CPU of the server
  process and of the browser's processes (psutil; % of one core); the frames of the session
  recorded meanwhile.
* **matplotlib**: :class:`psmat.live.LiveView` with the Agg backend in this process, driven
  as ``psmat view --simulate --seconds S`` drives it headless (update, then draw, without
  pause): frames drawn per second and this process's CPU (the twin, the reader and the view;
  nothing recorded).

A headless browser draws at most at its animation-frame rate (about 60 Hz) and the lab server
feeds it at its display rate (``--display-rate``, passed on to ``psmat lab``); the matplotlib figure is drawn whenever frames arrived. Neither
is a goal to meet: the table shows what each display costs on this machine.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from typing import Any

__all__ = ["main", "build_parser", "measure_matplotlib", "percentile", "run_all"]

PROG = "python -m psmat.bench lab"


def percentile(values: list[float], q: float) -> float:
    """The ``q``-th percentile (0-100) of ``values``, linear between order statistics; NaN when empty."""
    if not values:
        return math.nan
    xs = sorted(values)
    pos = (len(xs) - 1) * q / 100.0
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(xs) - 1)
    return xs[lo] + (xs[hi] - xs[lo]) * (pos - lo)


def measure_matplotlib(rate_hz: float, *, seconds: float, warmup_s: float) -> dict[str, Any]:
    """:class:`psmat.live.LiveView` (Agg) on a twin at ``rate_hz`` (frames/s): frames drawn/s and this
    process's CPU (% of one core) over ``seconds`` (s) after ``warmup_s`` (s)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import psutil

    from ..acquire import open_device
    from ..live import LiveView
    from ..twin import SerialTwin

    shape = (16, 16)
    twin = SerialTwin("psm", int(round(rate_hz)), "v2", shape=shape, scene="sway").start()
    me = psutil.Process()
    try:
        dev = open_device(twin.port, "psm", "v2", shape)
        try:
            dev.start()
            view = LiveView(dev)
            try:
                t_end = time.monotonic() + warmup_s
                while time.monotonic() < t_end:
                    view.update(timeout=0.05)
                    view.draw()
                cpu0, draws0, proc0 = sum(me.cpu_times()[:2]), view.draws, view.processed
                t0 = time.monotonic()
                while time.monotonic() - t0 < seconds:
                    view.update(timeout=0.05)
                    view.draw()
                elapsed = time.monotonic() - t0
                cpu1 = sum(me.cpu_times()[:2])
                return {"display": "matplotlib", "rate_hz": rate_hz, "seconds": elapsed,
                        "drawn_per_s": (view.draws - draws0) / elapsed,
                        "processed_per_s": (view.processed - proc0) / elapsed,
                        "process_cpu_pct": 100.0 * (cpu1 - cpu0) / elapsed}
            finally:
                view.close()
                plt.close(view.fig)
        finally:
            dev.close()
    finally:
        twin.stop()


def measure_lab(rate_hz: float, *, seconds: float, warmup_s: float, poll_s: float,
                display_hz: float | None = None) -> dict[str, Any]:
    """The lab page in headless Chromium against ``psmat lab --simulate --rate RATE_HZ`` (one row);
    ``display_hz``: the server's ``--display-rate`` (default: the command's)."""
    from .chromium import Chromium
    from .lab_page import measure_page, serve_lab

    extra = ["--rate", f"{rate_hz:g}"] + ([] if display_hz is None else ["--display-rate", f"{display_hz:g}"])
    with tempfile.TemporaryDirectory(prefix="psmat-bench-lab-") as tmp:
        with serve_lab(tmp, *extra) as server, Chromium() as browser:
            run = measure_page(server, browser, rate_hz, seconds=seconds, warmup_s=warmup_s, poll_s=poll_s)
    lat, drawn = run.latency_ms, run.drawn_latency_ms
    return {"display": "lab page", "rate_hz": rate_hz, "seconds": run.seconds, "drawn_per_s": run.drawn_per_s,
            "latency_samples": len(lat), "latency_median_ms": percentile(lat, 50.0),
            "latency_p95_ms": percentile(lat, 95.0), "drawn_latency_samples": len(drawn),
            "drawn_latency_median_ms": percentile(drawn, 50.0), "server_cpu_pct": run.server_cpu_pct,
            "browser_cpu_pct": run.browser_cpu_pct, "recorded_frames": run.recorded_frames,
            "recorded_s": run.recorded_s, "server_rates": run.server_rates}


def run_all(rates: list[float], *, seconds: float, warmup_s: float, poll_s: float,
            display_hz: float | None = None) -> list[dict[str, Any]]:
    """Both displays at every rate: the lab page's row, then the matplotlib view's, per rate."""
    rows: list[dict[str, Any]] = []
    for rate in rates:
        rows.append(measure_lab(rate, seconds=seconds, warmup_s=warmup_s, poll_s=poll_s, display_hz=display_hz))
        rows.append(measure_matplotlib(rate, seconds=seconds, warmup_s=warmup_s))
    return rows


def _f(v: Any, spec: str, width: int) -> str:
    return f"{v:{width}{spec}}" if isinstance(v, (int, float)) and math.isfinite(v) else f"{'-':>{width}}"


def table(rows: list[dict[str, Any]]) -> list[str]:
    """The report's lines: one row per display and rate (a dash: not measured for that display)."""
    out = [f"{'display':<11} {'mat Hz':>6} {'drawn/s':>8} {'arrival ms':>10} {'p95 ms':>7} {'n':>5} "
           f"{'to drawn ms':>11} {'server/view CPU %':>17} {'browser CPU %':>13} {'recorded':>8} {'rec. Hz':>7}"]
    for r in rows:
        cpu = r.get("server_cpu_pct", r.get("process_cpu_pct"))
        n_rec, span = r.get("recorded_frames"), r.get("recorded_s")
        rec_hz = (n_rec - 1) / span if n_rec and span and math.isfinite(span) and span > 0 else math.nan
        out.append(f"{r['display']:<11} {_f(r['rate_hz'], 'g', 6)} {_f(r['drawn_per_s'], '.1f', 8)} "
                   f"{_f(r.get('latency_median_ms'), '.1f', 10)} {_f(r.get('latency_p95_ms'), '.1f', 7)} "
                   f"{_f(r.get('latency_samples'), 'd', 5)} {_f(r.get('drawn_latency_median_ms'), '.1f', 11)} "
                   f"{_f(cpu, '.0f', 17)} {_f(r.get('browser_cpu_pct'), '.0f', 13)} {_f(n_rec, 'd', 8)} "
                   f"{_f(rec_hz, '.1f', 7)}")
    return out


LEGEND = ("drawn/s: frames drawn per second; arrival ms: median latency from a frame's device time to its "
          "arrival in the page\n(the device clock mapped onto the host's by the least-delayed frame), p95 its 95th "
          "percentile, n its samples;\nto drawn ms: median time from the server receiving a frame to the page "
          "drawing it; CPU: % of one core;\nrecorded: frames in the session recorded meanwhile, rec. Hz their rate "
          "on the host clock")


def _rates(text: str) -> list[float]:
    try:
        rates = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"a comma-separated list of frame rates (Hz), got {text!r}") from None
    if not rates or not all(1 <= r <= 1000 and r == int(r) for r in rates):
        raise argparse.ArgumentTypeError(f"whole frame rates from 1 to 1000 Hz, got {text!r}")
    return rates


def _rates_one(text: str) -> float:
    rates = _rates(text)
    if len(rates) != 1:
        raise argparse.ArgumentTypeError(f"one rate (Hz), got {text!r}")
    return rates[0]


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of seconds, got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"a finite number of seconds > 0, got {text!r}")
    return v


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The benchmark's options (its help: this module's docstring, every default)."""
    from .._help import HelpFormatter, plain

    ap = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--rates", type=_rates, default="100,165",
                    help="the simulated mat's frame rates, comma-separated (frames/s)")
    ap.add_argument("--seconds", type=_positive, default=10.0, help="measured time of each display at each rate (s)")
    ap.add_argument("--warmup", type=_positive, default=2.0, help="time before each measurement (s)")
    ap.add_argument("--poll", type=_positive, default=0.02,
                    help="interval between reads of the page's figures, which sample the drawn latency (s)")
    ap.add_argument("--display-rate", type=_rates_one, default=None,
                    help="psmat lab's --display-rate: most display updates per second sent to the page (Hz; "
                         "default: psmat lab's)")
    ap.add_argument("--json", metavar="PATH", help="also write the figures to this JSON file")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --json file")
    return ap


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    from .._atomic import OutputRefused, check_outputs, open_atomic
    from .chromium import find_chromium
    from .machine import machine_info

    try:  # before any work: an existing file only with --overwrite
        check_outputs([args.json], overwrite=args.overwrite)
    except OutputRefused as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    missing = [m for m in ("websockets", "psutil", "starlette", "uvicorn") if not _importable(m)]
    if missing:
        print(f"{prog}: needs {', '.join(missing)} (pip install 'psmat[lab]' psutil)", file=sys.stderr)
        return 1
    exe = find_chromium()
    if exe is None:
        print(f"{prog}: no Chromium on PATH (Debian: apt-get install chromium; or set PSMAT_CHROMIUM)",
              file=sys.stderr)
        return 1
    info = machine_info()
    print(f"machine: {info['cpu']}, {info['usable_cpus']} usable CPUs; Python {info['python']}, psmat "
          f"{info['psmat']}; browser {exe}")
    print(f"each display {args.seconds:g} s after {args.warmup:g} s, at {', '.join(f'{r:g}' for r in args.rates)} Hz; "
          "CPU in % of one core")
    try:
        rows = run_all(args.rates, seconds=args.seconds, warmup_s=args.warmup, poll_s=args.poll,
                       display_hz=args.display_rate)
    except (RuntimeError, OSError) as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    for line in table(rows):
        print(line)
    print(LEGEND)
    if args.json:
        with open_atomic(args.json, "w") as f:
            json.dump({"machine": info, "seconds": args.seconds, "warmup_s": args.warmup,
                       "display_rate_hz": args.display_rate, "rows": rows}, f,
                      indent=1)
    return 0


def _importable(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None
