"""Time planning one hitting movement from a 300-primitive, 7-DoF library at 500 Hz over 0.5 s.

    python docs/examples/bench_momp.py [--repeats N] [--method weights|trajectories]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import argparse  # noqa: E402
import json  # noqa: E402

from tt_drake.benchmarks import bench_momp_planning  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=500)
    ap.add_argument("--method", default="weights", choices=["weights", "trajectories"])
    args = ap.parse_args()
    print(json.dumps(bench_momp_planning(repeats=args.repeats, method=args.method), indent=1))


if __name__ == "__main__":
    main()
