"""The predicted spin at impact in the learned player's stimulus (docs/motor_primitives.md): the
predictor's ``spin_hit`` output and the MoMP player's gating on it."""

import numpy as np
import pytest

from tt_drake.constants import PLANES
from tt_drake.hitting_point import PhysicalPredictor
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.stimulus import SPIN_STIMULUS
from tt_drake.systems.hitting_point_predictor import HittingPointPredictor
from tt_drake.systems.momp_player import MoMPTrajectorySource

from .test_momp_player import T_HIT, fix_inputs, synthetic_library
from .test_vision_systems import PERIOD, step


def test_predictor_publishes_the_spin_the_model_carries_to_the_plane():
    """From the fourth observation past plane s with the estimator's spin, the ball model's spin
    at the hitting plane: the robot-side bounce still ahead changes it."""
    pred = HittingPointPredictor()  # physical model
    ctx = pred.CreateDefaultContext()
    spin = np.array([60.0, 10.0, -5.0])
    pred.GetInputPort("spin").FixValue(ctx, spin)
    states = [np.array([0.1, 0.15 - 0.09 * k, 0.95, 0.1, -5.4, -1.0 - 0.16 * k]) for k in range(8)]
    for k, s in enumerate(states):
        pred.GetInputPort("state").FixValue(ctx, s)
        pred.GetInputPort("status").FixValue(ctx, [1.0, k * PERIOD])
        step(pred, ctx, k * PERIOD + 2 * PERIOD / 3)
    first_after = next(j for j, s in enumerate(states) if s[1] < PLANES.observation_y)
    physical = PhysicalPredictor()
    hit = physical.model.predict_plane(np.r_[states[first_after + 3], spin], physical.plane_y)
    assert hit.bounces  # the table bounce is between the observation and the plane
    out = pred.GetOutputPort("spin_hit").Eval(ctx)
    np.testing.assert_allclose(out, hit.spin, atol=1e-12)
    assert np.linalg.norm(out - spin) > 10.0
    np.testing.assert_allclose(pred.GetOutputPort("p_hit").Eval(ctx), hit.position, atol=1e-12)


def spin_library():
    """Six primitives; 0 and 1 share their (p_hit, v_hit) and differ only in spin (topspin
    against backspin, 80 rad/s about x)."""
    base, stages, stimuli = synthetic_library()
    spins = np.zeros((6, 3))
    stimuli[1] = stimuli[0]
    spins[0, 0], spins[1, 0] = 80.0, -80.0
    x = np.hstack([stimuli, spins])
    library = MotorPrimitiveLibrary(base.dmp, base.weights, base.amplitude, x,
                                    np.r_[np.ones(6), 30.0, 30.0, 30.0],
                                    stimulus_layout=SPIN_STIMULUS)
    return library, stages, x


@pytest.mark.parametrize("which", [0, 1])
def test_momp_player_gates_on_the_predicted_spin(which):
    library, stages, x = spin_library()
    player = MoMPTrajectorySource(library, stages)
    context = player.CreateDefaultContext()
    fix_inputs(player, context, x[which], T_HIT)
    player.GetInputPort("spin_hit").FixValue(context, x[which, 6:])
    context.SetTime(0.1)
    player.ExecuteForcedEvents(context)
    stroke = player.player_state(context).stroke
    np.testing.assert_array_equal(stroke.stimulus, x[which])
    heaviest = stroke.primitives[np.argmax(stroke.mixture)]
    assert heaviest == which and stroke.mixture.max() > 0.9


def test_a_spin_library_needs_the_spin_and_matching_layouts():
    library, stages, x = spin_library()
    player = MoMPTrajectorySource(library, stages)
    context = player.CreateDefaultContext()
    fix_inputs(player, context, x[0], T_HIT)  # spin_hit left unconnected
    context.SetTime(0.1)
    with pytest.raises(Exception, match="needs spin_hit"):
        player.ExecuteForcedEvents(context)
    library.stimulus_layout = None
    with pytest.raises(ValueError, match="stimulus layout p_hit, v_hit for a library whose "
                                         "stimuli have 9 values"):
        MoMPTrajectorySource(library, stages)
