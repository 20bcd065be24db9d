"""Compare two ``tt-drake serve --json`` outputs of the same serves, serve by serve.

    python docs/examples/compare_serves.py A.json B.json [--tol 0.001]

Prints the number of serves, the largest landing-point shift and every serve whose outcome,
faults or landing point (beyond ``--tol`` metres) differ; exit status 1 if any does. Used to
check that a speed-up keeps every outcome (docs/performance.md).
"""

from __future__ import annotations

import argparse
import json
import sys

from tt_drake.benchmarks import compare_serve_records


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--tol", type=float, default=1e-3, help="landing tolerance, m (1 mm)")
    args = ap.parse_args()
    with open(args.a) as fa, open(args.b) as fb:
        r = compare_serve_records(json.load(fa), json.load(fb), args.tol)
    print(f"{r['serves']} serves, {len(r['differ'])} differ, largest landing shift "
          f"{1e3 * r['max_landing_shift']:.2f} mm")
    for d in r["differ"]:
        print(f"  serve {d['index']} (seed {d['seed']}): {', '.join(d['fields'])}: "
              f"{d['a']} vs {d['b']}")
    return 0 if r["same"] else 1


if __name__ == "__main__":
    sys.exit(main())
