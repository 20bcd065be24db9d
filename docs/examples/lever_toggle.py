"""A lever on and off in one process, serve by serve (docs/performance.md, "One lever, one
process").

    OPENBLAS_NUM_THREADS=1 python docs/examples/lever_toggle.py segments [--player momp]
        [--serves 12] [--seed 3] [--perception camera|oracle] [--distribution D] [--record]
        [--scenario S]

Builds the serve diagram once, runs one warm-up episode, then runs each serve twice, once with
the lever and once without (the order alternating from serve to serve), and prints the CPU time
(``time.process_time``) per serve of each and their ratio. On a machine whose load changes from
minute to minute this compares the two under the same load, which runs of two checkouts one
after the other do not. Levers:

- ``segments``: the serve episode decides the integrator's accuracy once per referee tick
  (``advance_in_segments``) against ContactAccuracy's monitor after every integrator step;
- ``did-nothing``: the EKF's and the hitting-point predictor's ticks without anything new return
  ``EventStatus.DidNothing`` against returning nothing (the simulator then writes the unchanged
  state back);
- ``setpoint-table``: the player's servo set-points read from a table made once per plan and
  32 ticks (``StagePlanPlayer(setpoint_period=...)``, its ``setpoint_table``) against one plan
  evaluation per servo tick;
- ``hold-table``: the MoMP hold's check reads the plan's positions at the planning ticks from
  a table made per plan and 32 ticks against one plan evaluation per tick;
- ``momp-did-nothing``: the MoMP player's planning ticks without anything new return
  ``EventStatus.DidNothing`` against returning nothing;
- ``momp-tables``: the last three together;
- ``crossing-memo``: the hitting-point predictor integrates each plane crossing once per tick
  (``HittingPointPredictor._plane`` keeps the last) against integrating it for every caller;
- ``hold-check``: the MoMP player's safety check on Python floats
  (``momp_player.arm_follows``) against the numpy array expressions it replaced;
- ``guard``: the MoMP player's safety guard (the measured arm checked against the plan at every
  planning tick, ``MoMPConfig.hold_error``) on against off (off changes no outcome
  unless a stroke would have been held);
- ``prediction-step`` (analytical): the planner's ball model steps
  ``analytical_player.PREDICTION_STEP`` (10 ms) against 2 ms;
- ``prediction-cutoff`` (analytical): no prediction once the committed stroke is past its
  correction cut-off against predicting from every frame to the episode's end;
- ``close-aim`` (analytical): a correction's stroke solves its one flight time's outgoing
  velocity alone against ``aim_candidates`` on that one flight time (its clearance and racket
  speed computed and not used);
- ``teacher-all``: the last three together;
- ``quintic-kernel``: the quintic segments evaluated by the compiled kernel
  (``tt_drake/quintic_kernel.py``) against its numpy array expressions (``quintic_many_numpy``;
  for one time too);
- ``wrist-test`` (analytical): the inverse kinematics refuses a request whose wrist circle misses
  the elbow's reach without running the solver (``HittingIK.may_reach``) against the looser
  triangle-inequality bound (``REACH_BOUND``) it replaced.
- ``snopt-quiet``: the inverse kinematics' SNOPT at major print level 0
  (``hitting_ik.SNOPT_OPTIONS``) against its default level (the iteration cap alone), for the
  teacher's IK and an analytical hitting configuration's (a CrKR configuration solves none).
- ``ik-sqp`` (analytical): the inverse kinematics solved by the compiled SQP
  (``HittingIK(solver="sqp")``, ``teacher: {ik_solver: sqp}``) against SNOPT (the default).
- ``table-clearance``: the referee reads the plant's contact results only where the arm's
  joint angles let it reach the table top (``Referee.table_clearance``,
  ``systems/table_clearance.py``) against at every sample.

``--perception oracle --record`` plays the serves as the paper protocol's teacher stage does
(``tt-drake collect --perception oracle``).

It also counts the serves whose outcome and episode duration are equal both ways (``did-nothing``,
``setpoint-table``, ``hold-table``, ``momp-did-nothing``, ``crossing-memo``, ``quintic-kernel``,
``wrist-test``, ``snopt-quiet``, ``table-clearance`` and ``hold-check`` change no number;
``ik-sqp`` changes strokes by the solvers' tolerances, so the outcome check for it is
``compare_serves.py`` on 100 serves; ``segments`` may move the integrator's steps, and the
outcome check for it is ``compare_serves.py`` on 100 serves).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import statistics
import time
import types

import numpy as np

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set
from tt_drake.quintic_kernel import quintic_many_numpy
from tt_drake.stages import Quintic
from tt_drake.systems.hitting_ik import (
    REACH_BOUND,
    SHOULDER,
    SNOPT_OPTIONS,
    HittingIK,
    snopt_options,
)

_DID_NOTHING_MODULES = ("tt_drake.systems.ball_flight_estimator",
                        "tt_drake.systems.hitting_point_predictor")
_PLAYERS = ("momp_player", "analytical_player")  # the crkr player is "momp_player" too


def _arm_follows_numpy(x, q, velocity, hold_speed, hold_error) -> bool:
    """``momp_player.arm_follows`` as numpy array expressions (the ``hold-check`` lever off)."""
    return bool((np.abs(x[7:]) <= hold_speed * velocity).all()
                and float(np.abs(x[:7] - q).max()) <= hold_error)


def _aims_before(self, p_hit, v_hit, spin, previous):
    """``StrokePlanner.aims`` without the close-aim lever: a correction's flight time ranked
    through aim_candidates too."""
    from tt_drake.racket_law import aim_candidates

    cfg = self.config
    times = (previous.flight_time,) if previous is not None else cfg.flight_times
    return [(aim.v_out, aim.flight_time)
            for aim in aim_candidates(p_hit, v_hit, (cfg.target_x, cfg.target_y),
                                      flight_times=times, spin=spin)]


def toggles(diagram: ServeDiagram) -> dict:
    schedule = diagram._schedule
    nothing = {m: importlib.import_module(m)._NOTHING for m in _DID_NOTHING_MODULES}

    def segments(on: bool) -> None:
        diagram._schedule = schedule if on else None  # None: AdvanceTo with the monitor

    def did_nothing(on: bool) -> None:
        for m, status in nothing.items():
            importlib.import_module(m)._NOTHING = status if on else None

    def player():
        name = next(n for n in _PLAYERS if diagram.diagram.HasSubsystemNamed(n))
        return diagram.diagram.GetSubsystemByName(name)

    ticks = player().setpoint_table.ticks

    def setpoint_table(on: bool) -> None:
        player().setpoint_table.ticks = ticks if on else 0  # 0: one evaluation per servo tick

    def hold_table(on: bool) -> None:
        player()._planned.ticks = ticks if on else 0

    momp = importlib.import_module("tt_drake.systems.momp_player")
    momp_nothing = momp._NOTHING

    def momp_did_nothing(on: bool) -> None:
        momp._NOTHING = momp_nothing if on else None

    def momp_tables(on: bool) -> None:
        for lever in (setpoint_table, hold_table, momp_did_nothing):
            lever(on)

    def crossing_memo(on: bool) -> None:
        predictor = diagram.diagram.GetSubsystemByName("hitting_point_predictor")
        if on:
            predictor.__dict__.pop("_plane", None)
        else:
            predictor._plane = lambda model, state9, plane_y: model.predict_plane(state9, plane_y)

    import dataclasses

    guarded = getattr(player(), "config", None)  # the MoMP player's

    def guard(on: bool) -> None:
        player().config = guarded if on else dataclasses.replace(guarded, hold_error=None)

    follows = momp.arm_follows

    def hold_check(on: bool) -> None:
        momp.arm_follows = follows if on else _arm_follows_numpy

    def analytical():
        return diagram.diagram.GetSubsystemByName("analytical_player")

    def prediction_step(on: bool) -> None:
        from tt_drake.systems.analytical_player import PREDICTION_STEP, planner_ball_model

        analytical().planner.model = planner_ball_model(PREDICTION_STEP if on else 2e-3)

    def prediction_cutoff(on: bool) -> None:
        analytical().predict_past_cutoff = not on

    def close_aim(on: bool) -> None:
        planner = analytical().planner
        if on:
            planner.__dict__.pop("aims", None)
        else:
            planner.aims = types.MethodType(_aims_before, planner)

    def teacher_all(on: bool) -> None:
        for lever in (prediction_step, prediction_cutoff, close_aim):
            lever(on)

    compiled = (Quintic.evaluate, Quintic.evaluate_many)

    def quintic_kernel(on: bool) -> None:
        if on:
            Quintic.evaluate, Quintic.evaluate_many = compiled
            return

        def evaluate_many(self, times):
            return quintic_many_numpy(self.coeffs, self.t0, self.duration, times)

        def evaluate(self, t):
            return tuple(x[0] for x in evaluate_many(self, [t]))

        Quintic.evaluate, Quintic.evaluate_many = evaluate, evaluate_many

    wrist_test = HittingIK.may_reach

    def wrist_test_lever(on: bool) -> None:
        HittingIK.may_reach = wrist_test if on else (
            lambda self, p_hit, normal: bool(np.linalg.norm(p_hit - SHOULDER) <= REACH_BOUND))

    planners = [diagram.diagram.GetSubsystemByName(name).planner
                for name in ("analytical_player", "hitting_configuration")
                if diagram.diagram.HasSubsystemNamed(name)]
    arms = [planner.arm for planner in planners if planner is not None]  # a CrKR source has none
    quiet = [arm.solver_options for arm in arms]
    loud = snopt_options({k: v for k, v in SNOPT_OPTIONS.items() if k != "Major print level"})

    def snopt_quiet(on: bool) -> None:
        for arm, options in zip(arms, quiet, strict=True):
            arm.solver_options = options if on else loud

    def ik_sqp(on: bool) -> None:
        for arm in arms:
            arm.solver = "sqp" if on else "snopt"

    referee = diagram.station.referee
    clearance = referee.table_clearance

    def table_clearance(on: bool) -> None:
        referee.table_clearance = clearance if on else None

    return {"quintic-kernel": quintic_kernel, "wrist-test": wrist_test_lever,
            "snopt-quiet": snopt_quiet, "ik-sqp": ik_sqp, "table-clearance": table_clearance,
            "prediction-step": prediction_step,
            "prediction-cutoff": prediction_cutoff, "close-aim": close_aim,
            "teacher-all": teacher_all,
            "segments": segments, "did-nothing": did_nothing, "setpoint-table": setpoint_table,
            "hold-table": hold_table, "momp-did-nothing": momp_did_nothing,
            "momp-tables": momp_tables, "crossing-memo": crossing_memo, "guard": guard,
            "hold-check": hold_check}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("lever", choices=("segments", "did-nothing", "setpoint-table", "hold-table",
                                      "momp-did-nothing", "momp-tables", "crossing-memo",
                                      "guard",
                                      "prediction-step", "prediction-cutoff", "close-aim",
                                      "teacher-all", "quintic-kernel", "wrist-test",
                                      "snopt-quiet", "ik-sqp", "table-clearance", "hold-check"))
    ap.add_argument("--player", default="momp")
    ap.add_argument("--serves", type=int, default=12)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--perception", default=None, help="camera or oracle (default: scenario's)")
    ap.add_argument("--distribution", default=None, help="the launcher's serves (e.g. spin)")
    ap.add_argument("--record", action="store_true", help="record demonstrations (collect's)")
    add_scenario_option(ap)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    if args.perception is not None:
        scenario = dataclasses.replace(scenario, perception=args.perception)
    if args.distribution is not None:
        scenario = dataclasses.replace(scenario, launcher=dataclasses.replace(
            scenario.launcher, distribution=args.distribution))
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    diagram = ServeDiagram(scenario, args.player, record=args.record)
    toggle = toggles(diagram)[args.lever]
    diagram.run(episode_seed(args.seed, 0))
    cpu = {False: [], True: []}
    results = {False: [], True: []}
    for i in range(args.serves):
        for on in ((True, False) if i % 2 else (False, True)):
            toggle(on)
            c0 = time.process_time()
            r = diagram.run(episode_seed(args.seed, i))
            cpu[on].append(time.process_time() - c0)
            results[on].append((r.outcome.as_dict(), r.duration))
    toggle(True)
    off, on = sum(cpu[False]), sum(cpu[True])
    per_serve = [a / b for a, b in zip(cpu[False], cpu[True], strict=True)]
    same = sum(a == b for a, b in zip(results[False], results[True], strict=True))
    n = args.serves
    print(f"{args.lever}, {args.player} ({scenario.perception}, "
          f"{scenario.launcher.distribution} serves{', recorded' if args.record else ''}), "
          f"{n} serves (seed {args.seed}): without "
          f"{1e3 * off / n:.1f}, with {1e3 * on / n:.1f} CPU ms per serve; without / with "
          f"{off / on:.3f} (median per serve {statistics.median(per_serve):.3f}); outcome and "
          f"duration equal in {same} of {n}")


if __name__ == "__main__":
    main()
