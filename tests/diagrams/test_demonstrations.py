"""Recorded demonstrations (docs/motor_primitives.md section 10): the arm's measured joint state
during the teacher's stroke, and a DMP imitating it."""

import numpy as np
import pytest

from tt_drake.diagrams.demonstrations import SAMPLE_RATE
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.train import stage_runs
from tt_drake.dmp import HittingDMP
from tt_drake.imitation import Demonstration, imitate
from tt_drake.stages import HITTING, STAGES

HIT = STAGES.index(HITTING)


@pytest.fixture(scope="module")
def episode():
    diagram = ServeDiagram(load_scenario(), "analytical", record=True)
    result = diagram.run(episode_seed(5, 0))
    assert result.outcome.hit
    return diagram, result


def test_recorded_rows_are_the_logged_plant_state(episode):
    """At every sample the recorder shares with the episode's own arm logger (250 Hz, another
    VectorLogSink on the plant's state port), q and q_dot are the same numbers, bit for bit."""
    diagram, result = episode
    rec = result.record["recorded"]
    log = diagram.arm_logger.FindLog(diagram.context)
    t_ref, x_ref = log.sample_times(), log.data().T
    k = np.clip(np.searchsorted(t_ref, rec[:, 0]), 0, len(t_ref) - 1)
    same = np.abs(t_ref[k] - rec[:, 0]) < 1e-9
    assert same.sum() >= len(rec) // 2 - 1  # every other 500 Hz sample is a 250 Hz one
    np.testing.assert_array_equal(rec[same, 2:16], x_ref[k[same]])


def test_recorded_hitting_stage_is_a_500hz_grid_up_to_the_hit(episode):
    """The hitting stage's rows are consecutive 500 Hz samples inside the stage, the last within
    one servo period of its end: t_hit, or the racket's contact with the ball if that came first
    (the referee reports it at its first 250 Hz tick after); its velocities integrate the logged
    accelerations."""
    diagram, result = episode
    rec = result.record["recorded"]
    rows = [r for s, r in stage_runs(rec) if s == HIT][0]
    end = min(result.record["stimulus"][6],
              result.outcome.hit_time - 1.0 / diagram.scenario.referee_rate)
    assert np.allclose(np.diff(rows[:, 0]), 1.0 / SAMPLE_RATE, atol=1e-9)
    assert end - 1.0 / SAMPLE_RATE - 1e-9 <= rows[-1, 0] <= end + 1e-9
    # It starts within one servo period of the executed plan's hitting stage (a correction
    # during the stage can move the plan's stage start within the period its row was logged in).
    plan = [r for s, r in stage_runs(result.record["trajectory"]) if s == HIT][0]
    assert abs(rows[0, 0] - plan[0, 0]) < 1.0 / SAMPLE_RATE
    # q_ddot is the plant's acceleration: the trapezoidal integral of it over each 2 ms step
    # gives the logged change of q_dot, to within how much the acceleration changes inside a
    # step (the set-points are held for a servo period, the PD feedback, the dynamics and the
    # drives' speed-dependent torque bound move on: a fifth of the peak at worst where a drive
    # enters or leaves its bound inside a step, a fiftieth in the median); the racket's
    # impact, in the last samples, is excluded.
    qd, qdd = rows[:-2, 9:16], rows[:-2, 16:23]
    rate = np.diff(qd, axis=0) * SAMPLE_RATE
    trapezoid = 0.5 * (qdd[1:] + qdd[:-1])
    assert np.abs(rate - trapezoid).max() < 0.2 * np.abs(qdd).max()
    assert np.median(np.abs(rate - trapezoid)) < 0.02 * np.abs(qdd).max()


def test_a_dmp_imitating_a_recorded_demonstration_reproduces_it(episode):
    """Eqs. 7-8 on the recorded hitting stage (with its tracking error and the controller's
    500 Hz torque steps in q_ddot). Bound: the reproduced racket stays within 1 cm of the
    recorded racket over the whole stage, an eighth of the blade's 76 mm radius (measured on
    100 recorded strokes: joint RMSE 8e-4 rad median, docs/motor_primitives.md), and it arrives
    at the recorded hitting posture to the same 1 cm (the impact's spike in the last samples'
    q_ddot is not representable by 30 basis functions: the arrival is mrad, not 1e-5 rad)."""
    from tt_drake.systems.hitting_ik import HittingIK

    _, result = episode
    rows = [r for s, r in stage_runs(result.record["recorded"]) if s == HIT][0]
    demo = Demonstration(rows[:, 0] - rows[0, 0], rows[:, 2:9], rows[:, 9:16], rows[:, 16:23])
    dmp = HittingDMP()
    rep = imitate(dmp, demo).rollout(dmp, n_steps=len(demo.t) - 1)
    arm = HittingIK()
    k = np.r_[np.arange(0, len(demo.t), 5), len(demo.t) - 1]
    gap = [np.linalg.norm(arm.racket_pose(a).translation() - arm.racket_pose(b).translation())
           for a, b in zip(rep.q[k], demo.q[k], strict=True)]
    assert max(gap) < 0.01
    assert np.sqrt(np.mean((rep.q - demo.q) ** 2)) > 0.0  # not the plan's exact quintic
