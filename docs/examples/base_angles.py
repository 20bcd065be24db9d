"""The base joint's angle the teacher's hitting postures ask for across the hitting region,
beside the awaiting posture's (docs/analytical_player.md, "Drives").

    python docs/examples/base_angles.py [--z 1.0] [--normal -0.15 0.9 0.4]

Solves the teacher's hitting IK (:class:`tt_drake.systems.hitting_ik.HittingIK`: the blade
centre on the hitting point, the racket facing ``--normal``, closest to the hitting comfort
posture) for hitting points on the virtual hitting plane from 0.3 m to the backhand to 0.8 m to
the forehand, ``--z`` high, and prints each answer's base angle and its distance from
``wam_params.AWAITING``'s base angle and from the stock teacher's (``teacher.awaiting_base``).
"""

from __future__ import annotations

import argparse

import numpy as np

from tt_drake.constants import PLANES
from tt_drake.diagrams.scenario import TeacherConfig
from tt_drake.systems.hitting_ik import HittingIK
from tt_drake.wam_params import AWAITING

CROSSINGS_X = (-0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)


def base_angles(z: float = 1.0, normal=(-0.15, 0.9, 0.4), crossings=CROSSINGS_X) -> list:
    """(x, base angle) of the IK's answer for each hitting point (x, hitting plane, z) that
    the arm reaches facing ``normal``; an unreachable point is left out."""
    arm = HittingIK()
    out = []
    for x in crossings:
        answer = arm.solve([x, PLANES.hitting_y, z], np.asarray(normal, dtype=float))
        if answer.success:
            out.append((float(x), float(answer.q[0])))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--z", type=float, default=1.0, help="hitting height, m (default 1.0)")
    parser.add_argument("--normal", type=float, nargs=3, default=(-0.15, 0.9, 0.4),
                        help="the racket's normal (need not be unit; default -0.15 0.9 0.4)")
    args = parser.parse_args(argv)
    stock = TeacherConfig().awaiting_base
    print(f"awaiting base angle: {AWAITING[0]:+.2f} rad (wam_params.AWAITING), "
          f"{stock:+.2f} rad (the stock teacher)")
    print("   x (m)   base (rad)   from AWAITING   from the stock teacher's")
    for x, base in base_angles(args.z, args.normal):
        print(f"  {x:+.2f}     {base:+.2f}         {base - AWAITING[0]:+.2f}            "
              f"{base - stock:+.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
