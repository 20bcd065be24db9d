"""Measurements behind docs/motor_primitives.md section 10 (recorded demonstrations, the gain).

    .venv/bin/python docs/examples/library_measures.py DATASET [--train 100] [--what all]

DATASET is a teacher dataset of ``tt-drake collect`` (it must hold the recorded arm states).
The first ``--train`` successful strokes train the libraries, the next ones are the held-out tasks.

- ``tracking``: the arm's recorded hitting stage against the plan it executed (the controller's
  tracking error), and how well a DMP imitates a recorded demonstration;
- ``borrow``: for each way of borrowing weak joints' shapes, the share of joint DoFs that borrow
  and, for every held-out stroke planned from rest at the awaiting posture ``lead`` seconds
  before its hit (0.3, 0.45 or 0.6 s of preparation before a 0.4 s hitting stage; the player's
  order of hitting-stage durations), the share whose first plan
  leaves the joint limits and the share with no plan inside them;
- ``spread``: per DMP gain alpha_y, every primitive of the library rolled out alone on each
  held-out stroke's hitting task (from rest at q_prep to (theta_hit, theta_dot_hit) in 0.4 s):
  the spread of the racket's position and velocity at the hitting time over the primitives.
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

from tt_drake.diagrams.collect import load_dataset
from tt_drake.diagrams.train import extract_strokes, stage_runs, train_library
from tt_drake.dmp import HittingDMP
from tt_drake.drives import joint_limits
from tt_drake.imitation import imitate
from tt_drake.learned_player import load_player_library, plan_momp_stroke, within_limits
from tt_drake.stages import HITTING, STAGES, StageTimes
from tt_drake.systems.momp_player import MoMPConfig
from tt_drake.wam_params import AWAITING

HIT = STAGES.index(HITTING)


def held_out(data, n_train):
    ok = np.flatnonzero(data["returned"] > 0.5)
    return ok[n_train:]


def tracking(data, n_train):
    errs, vel, rmse = [], [], []
    dmp = HittingDMP()
    for i in np.flatnonzero(data["returned"] > 0.5)[:n_train]:
        plan = [r for s, r in stage_runs(data["trajectory"][data["trajectory_serve"] == i])
                if s == HIT][0]
        rec = [r for s, r in stage_runs(data["recorded"][data["recorded_serve"] == i])
               if s == HIT][0]
        q_plan = np.array([np.interp(rec[:, 0], plan[:, 0], plan[:, 2 + j]) for j in range(7)]).T
        qd_plan = np.array([np.interp(rec[:, 0], plan[:, 0], plan[:, 9 + j])
                            for j in range(7)]).T
        errs.append(np.abs(rec[:, 2:9] - q_plan).max())
        vel.append(np.abs(rec[:, 9:16] - qd_plan).max())
        demo = extract_strokes({**data, "returned": (np.arange(len(data["returned"])) == i)
                                .astype(float)}, 1, "recorded")["hitting"][0]
        res = imitate(dmp, demo)
        rep = res.rollout(dmp, n_steps=len(demo.t) - 1)
        rmse.append(np.sqrt(np.mean((rep.q - demo.q) ** 2)))
    print(f"tracking error over {len(errs)} hitting stages: max |q_rec - q_plan| median "
          f"{np.median(errs):.2e} rad, worst {max(errs):.2e}; max |qd| median "
          f"{np.median(vel):.2e} rad/s, worst {max(vel):.2e}")
    print(f"DMP (alpha_y 35) imitating the recorded stages: RMSE median {np.median(rmse):.2e} "
          f"rad, worst {max(rmse):.2e}")


def build(dataset, n_train, **kwargs):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "lib.npz"
        summary = train_library(dataset, out, n_train, **kwargs)
        library, stages, _ = load_player_library(out)
    return library, stages, summary


def player_plan(library, stages, data, i, lead):
    """(first plan leaves the limits, no plan inside them) for serve i planned from rest at the
    awaiting posture ``lead`` s before its hit, as the MoMP player tries its plans."""
    cfg, limits = MoMPConfig(), joint_limits()
    q_aw = np.asarray(AWAITING, dtype=float)
    zero = np.zeros(7)
    stim = library.stimuli.shape[1]
    x = np.r_[data["stimulus"][i, :6], data["spin_hit"][i]][:stim]
    t_hit = 1.0
    first = None
    for hitting in (*cfg.hitting_durations, None):
        try:
            plan, _, _ = plan_momp_stroke(t_hit - lead, (q_aw, zero, zero), x, t_hit,
                                          data["q_hit"][i], data["qd_hit"][i], library, stages,
                                          q_aw, limits, StageTimes(min_preparation=0.1), False,
                                          hitting=hitting, prepare=hitting is not None)
        except ValueError:
            continue
        ok = within_limits(plan, limits)
        first = ok if first is None else first
        if ok:
            return not first, False
    return True, True


def borrow(dataset, data, n_train, demonstrations, alpha_y=35.0):
    tests = held_out(data, n_train)
    variants = {"hitting 0.5, stages 0.5 (before)": (0.5, 0.5),
                "hitting 0.25, stages 0.5": (0.25, 0.5), "hitting 0, stages 0.5": (0.0, 0.5),
                "hitting 0.5, stages 0": (0.5, 0.0), "none": (0.0, 0.0)}
    print(f"borrowing, {demonstrations} demonstrations, alpha_y {alpha_y:g}, {len(tests)} "
          f"held-out strokes:")
    for name, (hb, sb) in variants.items():
        library, stages, summary = build(dataset, n_train, demonstrations=demonstrations,
                                         hitting_borrow=hb, stage_borrow=sb,
                                         dmp=HittingDMP(alpha_y=alpha_y))
        for lead in (0.7, 0.85, 1.0):
            res = np.array([player_plan(library, stages, data, i, lead) for i in tests])
            print(f"  {name}: {summary['borrowed_share']:.1%} of hitting DoFs borrow; lead "
                  f"{lead} s: first plan leaves limits {res[:, 0].mean():.0%}, none inside "
                  f"{res[:, 1].mean():.0%}")


def spread(dataset, data, n_train, demonstrations, gains):
    from tt_drake.systems.hitting_ik import HittingIK

    arm = HittingIK()
    tests = held_out(data, n_train)
    tau = 0.4
    print(f"racket state at the hit over the primitives, {len(tests)} held-out tasks, "
          f"{demonstrations} demonstrations (median over tasks of the max deviation from the "
          f"goal's; in brackets the median over tasks of the primitives' std):")
    for alpha_y in gains:
        dmp = HittingDMP(alpha_y=alpha_y)
        library, _, _ = build(dataset, n_train, demonstrations=demonstrations, dmp=dmp)
        dp, dv, sp, sv, dn = [], [], [], [], []
        for i in tests:
            q_hit, qd_hit = data["q_hit"][i], data["qd_hit"][i]
            q_prep = q_hit - 0.5 * tau * qd_hit
            traj = library.rollout_all(q_prep, q_hit, qd_hit, tau, n_steps=200)
            goal_p = arm.racket_pose(q_hit).translation()
            goal_n = arm.racket_pose(q_hit).rotation().matrix()[:, 1]
            n = np.array([arm.racket_pose(q).rotation().matrix()[:, 1] for q in traj.q[:, -1]])
            dn.append(np.degrees(np.arccos(np.clip(n @ goal_n, -1.0, 1.0))).max())
            goal_v = arm.racket_velocity(q_hit, qd_hit)[3:]
            p = np.array([arm.racket_pose(q).translation() for q in traj.q[:, -1]])
            v = np.array([arm.racket_velocity(q, qd)[3:]
                          for q, qd in zip(traj.q[:, -1], traj.qd[:, -1], strict=True)])
            dp.append(np.linalg.norm(p - goal_p, axis=1).max())
            dv.append(np.linalg.norm(v - goal_v, axis=1).max())
            sp.append(np.sqrt(np.trace(np.cov(p.T))))
            sv.append(np.sqrt(np.trace(np.cov(v.T))))
        print(f"  alpha_y {alpha_y:g}: position {1e3 * np.median(dp):.3g} mm "
              f"({1e3 * np.median(sp):.3g}), velocity {np.median(dv):.3g} m/s "
              f"({np.median(sv):.3g}), normal {np.median(dn):.3g} deg")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("--train", type=int, default=100)
    ap.add_argument("--what", default="all", choices=("all", "tracking", "borrow", "spread"))
    ap.add_argument("--demonstrations", default="recorded")
    ap.add_argument("--gains", default="35,25,15,10,6")
    args = ap.parse_args()
    data = load_dataset(args.dataset)
    if args.what in ("all", "tracking"):
        tracking(data, args.train)
    if args.what in ("all", "borrow"):
        for gain in args.gains.split(","):
            borrow(args.dataset, data, args.train, args.demonstrations, float(gain))
    if args.what in ("all", "spread"):
        spread(args.dataset, data, args.train, args.demonstrations,
               [float(g) for g in args.gains.split(",")])


if __name__ == "__main__":
    main()
