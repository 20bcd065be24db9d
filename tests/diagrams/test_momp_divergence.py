"""The learned player's two guards against a runaway arm (docs/learned_player.md, "Serve 135"),
in the Drake world: the station's arm under the inverse-dynamics controller, whose plant clamps
each actuator at its effort limit. The controller does not know of the clamp: it keeps computing
the other joints' torques for an acceleration the clamped joint does not make, and the arm can
run away. On the ideal robot (``models/ideal_robot.yaml``), where the runaway was found: the
stock drives' back EMF caps each joint near its no-load speed, so that arm cannot run away.

The guards are tested on a ``momp`` stroke of the synthetic primitive library of
tests/systems/test_momp_player.py, with the prediction held constant and changed by hand: a
served ball makes a stroke that tests a guard only while an artefact set's strokes happen to ask
for it, and the sets are re-made.

- The hold: 0.1 s into the hitting stage the shoulder is thrown to 11 rad/s (1.1x its velocity
  limit: a measured state the plan does not expect, what a clamped shoulder does to the arm).
  Without the hold the arm runs away past 100 rad/s, so the kick is one the controller alone
  does not survive; with it the player abandons the stroke (a joint past 1.5x its velocity
  limit or 0.6 rad from the plan), plays the hold plan from the measured state, and the arm
  comes to rest at the awaiting posture.
- The moving goal's effort budget: 0.2 s into the hitting stage the goal's shoulder velocity
  moves by 2 rad/s, a move whose plan asks the shoulder for about 1.4x its effort limit. The
  budget of 1.2x (``momp_config(moving_goal=True)``) refuses it and no actuator saturates;
  under the paper profile's 1.5x it is accepted and the shoulder saturates.

And serve 135 of ``tt-drake serve --player momp --artefacts hard --distribution spin --seed
2027`` with the spinless hitting configuration, the stroke the 1.2x budget was set on with the
hard set of 0.1.0: with the shipped hard set it stays inside every effort, velocity and position
limit without the hold. That checks the set on that serve, not the budget: its stroke stays
inside the limits under a budget of 1.5x or 100x too.
"""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink

import tt_drake.diagrams.episodes as episodes
import tt_drake.systems.hitting_configuration as hitting_configuration
from tt_drake.arm_metrics import arm_metrics
from tt_drake.diagrams.episodes import SETPOINT_LEAD, ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.station import add_station, arm_port, awaiting_posture
from tt_drake.models import use_artefact_set
from tt_drake.stages import AWAITING, HITTING
from tt_drake.systems.hitting_ik import HittingIK
from tt_drake.systems.momp_player import (
    MOVING_GOAL_CUTOFF,
    MoMPConfig,
    MoMPTrajectorySource,
    momp_config,
)
from tt_drake.systems.wam import add_servo_hold, hold_first_setpoint
from tt_drake.systems.world import make_simulator
from tt_drake.wam_params import SERVO_PERIOD, VELOCITY_LIMIT

from ..systems.test_momp_player import Q_AWAIT, Q_HIT, QD_HIT, T_HIT, synthetic_library

pytestmark = pytest.mark.slow

SEED, INDEX = 2027, 135
SHOULDER = 0
LOG_PERIOD = 0.004  # s: the arm logged at the planning rate


class StrokeOnTheArm:
    """A stroke of the momp player (``config``, with the effort check's inverse dynamics) on the
    station's arm, from rest at the awaiting posture at 0 s, the prediction constant (the hit at
    ``T_HIT``) until changed; the arm's state and commanded torques logged."""

    def __init__(self, config: MoMPConfig):
        scenario = load_scenario("ideal_robot")
        builder = DiagramBuilder()
        station = add_station(builder, scenario, robots=1, launcher=False, referee=False,
                              aerodynamics=False)
        self.plant, self.robot = station.world.plant, station.world.robot
        library, stages, stimuli = synthetic_library()
        self.player = builder.AddNamedSystem("momp_player", MoMPTrajectorySource(
            library, stages, config=config, arm=HittingIK(), setpoint_lead=SETPOINT_LEAD,
            setpoint_period=SERVO_PERIOD))
        self.sources = {}
        for name, value in (("p_hit", stimuli[0][:3]), ("v_hit", stimuli[0][3:6]),
                            ("t_hit", [T_HIT]), ("theta_hit", Q_HIT), ("theta_dot_hit", QD_HIT),
                            ("configuration_valid", [1.0])):
            source = self.sources[name] = builder.AddSystem(
                ConstantVectorSource(np.asarray(value, dtype=float)))
            builder.Connect(source.get_output_port(), self.player.GetInputPort(name))
        arm_state = self.plant.get_state_output_port(self.robot)
        builder.Connect(arm_state, self.player.GetInputPort("arm_state"))
        add_servo_hold(builder, self.player.GetOutputPort("setpoint"), station.controllers[0])
        self.logs = {}
        for name, port, size in (("arm", arm_state, 14),
                                 ("torque", station.GetOutputPort(arm_port(0, "torque")), 7),
                                 ("desired", self.player.GetOutputPort("desired_state"), 14)):
            self.logs[name] = builder.AddSystem(VectorLogSink(size, LOG_PERIOD))
            builder.Connect(port, self.logs[name].get_input_port())
        diagram = builder.Build()
        self.simulator = make_simulator(diagram, scenario.world, self.plant)
        self.context = self.simulator.get_mutable_context()
        awaiting_posture(station.world, self.context)
        hold_first_setpoint(diagram, self.context)
        self.simulator.Initialize()
        self.simulator.AdvanceTo(0.05)  # planned at the first planning tick
        self.hitting_start = next(seg for stage, seg in self.state().plan.segments
                                  if stage == HITTING).t0

    def state(self):
        return self.player.player_state(self.player.GetMyContextFromRoot(self.context))

    def advance_to(self, t: float) -> None:
        self.simulator.AdvanceTo(t)

    def kick(self, joint: int, speed: float) -> None:
        """Set the arm's measured velocity of ``joint`` to ``speed`` (rad/s)."""
        plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        v = self.plant.GetVelocities(plant_context, self.robot).copy()
        v[joint] = speed
        self.plant.SetVelocities(plant_context, self.robot, v)

    def predict(self, name: str, value) -> None:
        """A new value of prediction input ``name`` (e.g. ``theta_dot_hit``)."""
        source = self.sources[name]
        context = source.GetMyMutableContextFromRoot(self.context)
        source.get_mutable_source_value(context).set_value(np.asarray(value, dtype=float))

    def log(self, name: str):
        """(times, samples) of log ``name`` (``arm``, ``torque``, ``desired``)."""
        log = self.logs[name].FindLog(self.context)
        return log.sample_times(), log.data().T

    def metrics(self) -> dict:
        _, x = self.log("arm")
        _, tau = self.log("torque")
        n = min(len(x), len(tau))
        return arm_metrics(x[:n, :7], x[:n, 7:], tau[:n])


def _thrown(config: MoMPConfig, after: float):
    """The stroke whose shoulder is thrown to 11 rad/s 0.1 s into its hitting stage, simulated
    ``after`` seconds past the kick; returns (the stroke, the kick's time)."""
    stroke = StrokeOnTheArm(config)
    t_kick = stroke.hitting_start + 0.1
    stroke.advance_to(t_kick)
    stroke.kick(SHOULDER, 1.1 * VELOCITY_LIMIT[SHOULDER])
    stroke.advance_to(t_kick + after)
    return stroke, t_kick


def test_an_arm_thrown_off_its_stroke_holds_and_comes_to_rest():
    stroke, t_kick = _thrown(MoMPConfig(), after=2.0)
    state = stroke.state()
    # The player abandoned the stroke and plays the hold plan: committed, every segment a
    # return to the awaiting posture, from a planning tick soon after the kick.
    assert state.stroke.held and state.committed
    assert {stage for stage, _ in state.plan.segments} == {AWAITING}
    assert t_kick < state.plan.segments[0][1].t0 <= t_kick + 0.1
    # The hold plan starts from the measured state, so the controller's feedback does not wind
    # up: the arm never passes 2x the velocity limit (the hold is triggered at 1.5x).
    t, x = stroke.log("arm")
    assert np.abs(x[t > t_kick, 7:]).max() < 2.0 * VELOCITY_LIMIT[0]
    # The desired state comes to rest at the awaiting posture, and the arm with it.
    _, desired = stroke.log("desired")
    np.testing.assert_allclose(desired[-1], np.r_[Q_AWAIT, np.zeros(7)], atol=1e-9)
    np.testing.assert_allclose(x[-1, :7], Q_AWAIT, atol=1e-3)
    assert np.abs(x[-1, 7:]).max() < 1e-3


def test_without_the_hold_the_same_arm_runs_away():
    """The control: with the efforts clamped, the inverse-dynamics controller alone does not
    recover from the kick."""
    stroke, t_kick = _thrown(MoMPConfig(hold_error=None), after=0.5)
    assert not stroke.state().stroke.held
    t, x = stroke.log("arm")
    assert np.abs(x[t > t_kick, 7:]).max() > 10.0 * VELOCITY_LIMIT[0]


@pytest.mark.parametrize("budget", [None, 1.5], ids=["moving goal's 1.2x", "1.5x"])
def test_the_moving_goal_budget_refuses_a_move_that_saturates_the_shoulder(budget):
    config = (momp_config(moving_goal=True) if budget is None
              else MoMPConfig(goal_cutoff=MOVING_GOAL_CUTOFF, torque_fraction=budget))
    stroke = StrokeOnTheArm(config)
    stroke.advance_to(stroke.hitting_start + 0.2 - 1e-3)
    moved = QD_HIT.copy()
    moved[SHOULDER] += 2.0
    stroke.predict("theta_dot_hit", moved)
    stroke.advance_to(T_HIT + 1.0)
    state, metrics = stroke.state(), stroke.metrics()
    assert not state.stroke.held and metrics["joint_limit_excess"] == 0.0
    if budget is None:  # refused at every tick until the cut-off: the stroke keeps its goal
        assert state.stroke.replans == 1
        np.testing.assert_array_equal(state.stroke.qd_hit, QD_HIT)
        assert metrics["saturated_fraction"] == 0.0
    else:  # accepted: the shoulder's command reaches its effort limit
        assert state.stroke.replans == 2
        np.testing.assert_array_equal(state.stroke.qd_hit, moved)
        assert metrics["saturated_samples_per_joint"][SHOULDER] > 0


class _Spinless(hitting_configuration.HittingConfiguration):
    def __init__(self, *args, use_spin=False, **kwargs):
        super().__init__(*args, use_spin=False, **kwargs)


@pytest.fixture
def spinless_configuration(monkeypatch):
    monkeypatch.setattr(episodes, "HittingConfiguration", _Spinless)  # what the diagram builds


def test_serve_135_of_the_shipped_hard_set_stays_inside_the_arms_limits(spinless_configuration):
    scenario = load_scenario("ideal_robot")
    use_artefact_set(scenario.learned, "hard")
    scenario.launcher.distribution = "spin"
    scenario.launcher.run_seed = SEED  # as `tt-drake serve --seed 2027` deals its serves
    result = ServeDiagram(scenario, "momp").run(episode_seed(SEED, INDEX))
    assert result.arm["joint_limit_excess"] == 0.0
    assert result.arm["max_joint_speed"] < VELOCITY_LIMIT[0]
    assert result.arm["saturated_fraction"] == 0.0
    assert not result.stroke.get("held", False)
