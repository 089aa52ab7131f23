"""``psmat demo``: crosstalk removal on a simulated mat; writes a figure."""

from __future__ import annotations

import argparse

NAME = "demo"
HELP = "crosstalk removal on a simulated mat; writes a figure"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="psmat_demo.png", help="figure path (PNG)")
    p.add_argument("--rows", type=int, default=16)
    p.add_argument("--cols", type=int, default=16)
    p.add_argument("--noise-mv", type=float, default=1.0, help="ADC-node voltage noise SD in mV")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--show", action="store_true", help="also open a window")


def run(args: argparse.Namespace) -> int:
    from ..demo import run_crosstalk_demo

    res = run_crosstalk_demo(args.out, rows=args.rows, cols=args.cols, noise_v=args.noise_mv * 1e-3,
                             seed=args.seed, show=args.show)
    print(f"psmat demo: simulated {args.rows}x{args.cols} mat, two feet, {args.noise_mv:g} mV noise, 12-bit ADC")
    print(f"  ghost (conductance outside the feet): {100 * res['ghost_fraction_raw']:.1f} % raw -> "
          f"{100 * res['ghost_fraction_iecm']:.2f} % after IECM")
    print(f"  centre-of-pressure error: {res['cop_error_raw_cm']:.3f} cm raw -> {res['cop_error_iecm_cm']:.4f} cm after IECM")
    print(f"  loaded cells: median relative error {res['loaded_cells_median_rel_error']:.2e}, "
          f"median propagated uncertainty {res['loaded_cells_median_rel_uncertainty']:.2e}")
    print(f"  IECM: {res['iterations']} iterations, status {res['status']}")
    print(f"  figure: {res['figure']}")
    return 0
