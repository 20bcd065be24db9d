"""Aerodynamics, BallLauncher and Referee tested through their ports, without a Simulator."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import BALL
from tt_drake.serves import ServeSampler
from tt_drake.systems.aerodynamics import AerodynamicsConfig, make_aerodynamics
from tt_drake.systems.ball_launcher import BallLauncher, LauncherConfig
from tt_drake.systems.referee import Referee


def ball_port_value(p, v, w=(0.0, 0.0, 0.0)):
    """The plant's 13-entry ball state: quaternion (wxyz), p, omega, v."""
    return np.r_[1.0, 0.0, 0.0, 0.0, p, w, v]


def test_aerodynamics_force_is_mass_times_the_model_acceleration_minus_gravity():
    aero = make_aerodynamics(num_velocities=13, ball_velocity_start=7)
    context = aero.CreateDefaultContext()
    v, w = np.array([1.0, -6.0, 2.0]), np.array([20.0, -50.0, 10.0])
    aero.GetInputPort("ball_state").FixValue(context, ball_port_value([0, 0, 1], v, w))
    force = aero.GetOutputPort("generalized_force").Eval(context)
    expected = np.array(BallModel().acceleration(tuple(v), tuple(w))) + [0, 0, 9.81]
    np.testing.assert_allclose(force[10:13], BALL.mass * expected, rtol=1e-12)
    assert np.all(force[:10] == 0.0)  # the arm and the ball's torque entries get nothing


def test_disabled_aerodynamics_applies_no_force():
    aero = make_aerodynamics(13, 7, AerodynamicsConfig(enabled=False))
    context = aero.CreateDefaultContext()
    aero.get_input_port(0).FixValue(context, ball_port_value([0, 0, 1], [1.0, -6.0, 2.0],
                                                             [20.0, -50.0, 10.0]))
    np.testing.assert_array_equal(aero.get_output_port(0).Eval(context), np.zeros(13))


def test_launcher_serve_is_a_pure_function_of_the_seed_parameter():
    launcher = BallLauncher(LauncherConfig("default"))
    context = launcher.CreateDefaultContext()
    launcher.set_seed(context, 42)
    first = launcher.GetOutputPort("launch_state").Eval(context).copy()
    np.testing.assert_array_equal(first, ServeSampler("default").sample(42).launch_state)
    launcher.set_seed(context, 43)
    assert not np.allclose(launcher.GetOutputPort("launch_state").Eval(context), first)
    launcher.set_seed(context, 42)
    np.testing.assert_array_equal(launcher.GetOutputPort("launch_state").Eval(context), first)


def run_referee(samples, rate=250.0):
    referee = Referee(rate=rate)
    context = referee.CreateDefaultContext()
    for t, p, v in samples:
        context.SetTime(t)
        referee.get_input_port(0).FixValue(context, ball_port_value(p, v))
        referee.ExecuteForcedEvents(context)  # the periodic sample, taken on demand
    return referee.GetOutputPort("outcome").Eval(context), referee.events(context)


def flight_samples(launch, duration, rate=250.0):
    model = BallModel()
    out = []
    for t in np.arange(0.0, duration, 1.0 / rate):
        c = model.predict_time(np.r_[launch, 0, 0, 0], t)
        out.append((t, c.position, c.velocity))
    return out


def test_referee_system_sees_the_bounce_and_calls_a_miss():
    samples = flight_samples(np.array([0.1, 1.57, 0.91, 0.25, -5.2, 3.0]), 1.2)
    outcome, events = run_referee(samples)
    assert [e.kind for e in events] == ["table"]
    assert events[0].position[1] == pytest.approx(-1.0, abs=0.15)
    assert outcome.outcome == "missed"


def test_referee_system_calls_a_hit_from_a_velocity_reversal():
    serve = flight_samples(np.array([0.1, 1.57, 0.91, 0.25, -5.2, 3.0]), 1.0)
    t_hit, p_hit, _ = serve[-1]
    back = flight_samples(np.r_[p_hit, 0.0, 5.0, 1.5], 0.3)
    samples = serve + [(t_hit + 0.004 + t, p, v) for t, p, v in back]
    outcome, events = run_referee(samples)
    assert [e.kind for e in events] == ["table", "racket"]
    assert outcome.hit and outcome.hit_time == pytest.approx(t_hit + 0.004)


class _CountingCentre:
    """A RacketCentre that counts its forward-kinematics calls."""

    def __init__(self, centre):
        self.centre, self.calls = centre, 0
        self.num_positions, self.state_size = centre.num_positions, centre.state_size

    def __call__(self, q):
        self.calls += 1
        return self.centre(q)


def test_referee_computes_the_racket_centre_only_for_a_contact_to_classify():
    from pydrake.systems.framework import DiagramBuilder

    from tt_drake import wam_params
    from tt_drake.systems.referee import RacketCentre
    from tt_drake.systems.wam import RACKET_CENTER_FRAME, awaiting_state, racket_pose
    from tt_drake.systems.world import add_world

    world = add_world(DiagramBuilder())
    plant = world.plant
    frame = plant.GetFrameByName(RACKET_CENTER_FRAME, world.robot)
    centre = _CountingCentre(RacketCentre(plant, world.robot, frame))
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, world.robot, np.asarray(wam_params.AWAITING))
    at_rest = racket_pose(plant, context, world.robot).translation()
    np.testing.assert_allclose(centre(wam_params.AWAITING), at_rest, atol=1e-12)
    centre.calls = 0

    referee = Referee(racket_centre=centre)
    rc = referee.CreateDefaultContext()
    referee.GetInputPort("robot_state").FixValue(rc, awaiting_state())
    # A ball flying at the racket centre, reflected there: one racket contact.
    v_in, v_out = np.array([0.0, -5.0, 0.0]), np.array([0.0, 4.0, 1.0])
    times = np.arange(0.0, 0.1, 0.004)
    t_hit = times[12] - 0.002
    for t in times:
        p = at_rest + (v_in * (t - t_hit) if t < t_hit else v_out * (t - t_hit))
        rc.SetTime(t)
        referee.get_input_port(0).FixValue(rc, ball_port_value(p, v_in if t < t_hit else v_out))
        referee.ExecuteForcedEvents(rc)
    assert [e.kind for e in referee.events(rc)] == ["racket"]
    assert centre.calls == 1  # 25 samples, one velocity jump: the racket centre read once
