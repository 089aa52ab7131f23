"""The IECM benchmark's report (:mod:`psmat.bench.iecm`): the Markdown table and plain JSON."""

from __future__ import annotations

import numpy as np

__all__ = ["format_table", "jsonable"]


def _fmt(x: float, spec: str) -> str:
    return "—" if x is None or not np.isfinite(x) else format(x, spec)


def format_table(result: dict) -> str:
    """Markdown table of the rows, the machine and the notes."""
    m = result["machine"]
    lines = [
        f"IECM benchmark — {m['date']}",
        f"machine: {m['cpu']}, {m['usable_cpus']} usable of {m['logical_cpus']} logical CPUs; "
        f"{m['platform']}; Python {m['python']}, NumPy {m['numpy']}, SciPy {m['scipy']}, psmat {m['psmat']} "
        f"(dense kernels: {m.get('psmat_simd', 'unknown')})",
        f"frames: two feet swaying on the digital twin (psmat.twin.swaying_feet, seed "
        f"{result['settings']['seed']}), noise-free; error = max |ĝ-g|/g over cells with g >= "
        f"{result['settings']['error_threshold_s']:g} S / over all cells",
        "",
        "| size | mode | solver | threads | frames | fps | fps/core | err g>=1e-4 | err all | iters | max it | "
        "resid | fact. | target |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    notes = []
    for r in result["rows"]:
        tgt = ""
        if r["target"]:
            tgt = ("met " if r["target_met"] else "MISSED ") + r["target"]
        fact = r.get("factorizations", float("nan"))
        ref = ""
        if r["note"]:
            notes.append(r["note"])
            ref = f" [{len(notes)}]"
        lines.append(
            f"| {r['size']}x{r['size']} | {r['mode']} | {r['solver']}{ref} | {r['threads']} | {r['frames']} | "
            f"{_fmt(r['fps'], '.4g')} | {_fmt(r['fps_per_core'], '.4g')} | {_fmt(r['err_loaded'], '.1e')} | "
            f"{_fmt(r['err_all'], '.1e')} | {_fmt(r['iterations'], '.1f')} | {_fmt(r['max_iterations'], '.0f')} | "
            f"{_fmt(r['max_residual'] if r['noise_v'] > 0 else float('nan'), '.1e')} | {_fmt(fact, '.2f')} | {tgt} |")
    lines.append("")
    for k, n in enumerate(notes, 1):
        lines.append(f"[{k}] {n}")
    for s in result.get("speedups", []):  # psmat's noisy streaming against the NumPy quick fixed point
        lines.append(f"- {s['line']}")
    for n in result["notes"]:
        lines.append(f"- {n}")
    lines.append("- streaming: consecutive frames, each warm-started from the previous solution, split in "
                 "one contiguous chunk per thread, chunk starts primed with the previous frame's solution; "
                 "cold: every frame from g0 = G. fps/core = fps / threads. max it: most iterations of one "
                 "frame; resid (noisy G): the largest complementarity residual max |phi| (Fischer-Burmeister, "
                 "docs/spec.md §3) over cells and frames, computed from the returned g for every solver alike.")
    return "\n".join(lines)


def jsonable(o):
    """Plain JSON: NumPy scalars/arrays to Python, NaN/inf to null."""
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return jsonable(o.tolist())
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float) and not np.isfinite(o):
        return None
    if o is None or isinstance(o, (bool, int, float, str)):
        return o
    return str(o)
