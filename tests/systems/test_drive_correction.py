"""The drive-aware correction of the controller's torque (systems/drive_correction.py): the free
joints get their commanded accelerations given the clamped joints' bounds (forward dynamics of
the corrected torques), nothing while no drive clamps (the episode to the bit), and the stock
wrist stays inside its limits on a stroke where the plain controller drove it past them."""

import dataclasses

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.scenario import ScenarioError, load_scenario, validate
from tt_drake.drives import DriveEnvelope, EffortBudget
from tt_drake.seeds import episode_seed
from tt_drake.systems.arm_dynamics import chain_of
from tt_drake.systems.drive_correction import clamped_correction
from tt_drake.systems.wam import make_control_plant

CHAIN = chain_of(make_control_plant())
N = wp.NUM_JOINTS


def _accelerations(q, v, tau):
    """Forward dynamics on the control plant's model: M(q)^-1 (tau - h(q, v))."""
    return np.linalg.solve(CHAIN.mass_matrix(q), tau - CHAIN.torques(q, v, np.zeros(N)))


@pytest.mark.parametrize("drive", [DriveEnvelope(wp.DESIGN_VOLTAGE), None])
def test_the_free_joints_get_their_commanded_accelerations_with_the_clamped_joints_at_bound(drive):
    bounds = EffortBudget(1.0, drive).bounds  # what the drives (or the effort limits) give
    rng = np.random.default_rng(3)
    clamped_cases = 0
    for _ in range(200):
        q = rng.uniform(np.asarray(wp.JOINT_LOWER), np.asarray(wp.JOINT_UPPER))
        v = rng.normal(0.0, 1.5, N)
        vd = rng.normal(0.0, 60.0, N)
        tau = CHAIN.torques(q, v, vd)
        lower, upper = bounds(v)
        correction = clamped_correction(CHAIN, bounds, q, v, vd)
        if np.all((tau >= lower) & (tau <= upper)):
            assert not correction.any()  # nothing clamps: exactly no correction
            continue
        applied = np.clip(tau + correction, lower, upper)  # what the drives let through
        free = (applied > lower) & (applied < upper)
        if not free.any():
            continue
        clamped_cases += 1
        a = _accelerations(q, v, applied)
        np.testing.assert_allclose(a[free], vd[free], rtol=1e-8, atol=1e-6)
        # The joints the drives clamp from the start keep their command; a joint the correction
        # took to its bound is at that bound.
        first = (tau < lower) | (tau > upper)
        assert np.all(correction[first] == 0.0)
        joined = ~free & ~first
        assert np.all(np.isclose(applied[joined], lower[joined])
                      | np.isclose(applied[joined], upper[joined]))
    assert clamped_cases > 20


def _episode(scenario, player, seed, index):
    scenario = dataclasses.replace(scenario, launcher=dataclasses.replace(
        scenario.launcher, run_seed=seed))
    diagram = ServeDiagram(scenario, player)
    return diagram.run(episode_seed(seed, index))


def test_an_episode_in_which_no_drive_clamps_is_the_controllers_to_the_bit():
    plain = load_scenario("default")
    aware = dataclasses.replace(plain, controller=dataclasses.replace(plain.controller,
                                                                     drive_aware=True))
    a = _episode(plain, "analytical", 7, 0)
    b = _episode(aware, "analytical", 7, 0)
    assert a.arm["saturated_fraction"] == 0.0
    assert a.outcome.as_dict() == b.outcome.as_dict()
    assert a.arm == b.arm and a.duration == b.duration


def test_the_stock_wrist_stays_inside_its_limits_where_the_plain_controller_passed_them():
    """rally-train validation serve 16 of seed 5101, without the joint stops: the plain
    controller drives joint 6 0.26 rad past its limit while the base's drive brakes
    (docs/examples/limit_excursions.py --no-stops)."""
    plain = load_scenario("default")
    plain = dataclasses.replace(plain, launcher=dataclasses.replace(
        plain.launcher, distribution="rally-train"))
    plain.world.joint_stops.enabled = False  # the plant alone: nothing stops the joint
    aware = dataclasses.replace(plain, controller=dataclasses.replace(plain.controller,
                                                                     drive_aware=True))
    before = _episode(plain, "analytical", 5101, 16)
    after = _episode(aware, "analytical", 5101, 16)
    assert before.arm["joint_limit_excess"] > 0.2
    assert after.arm["joint_limit_excess"] <= 0.0
    assert after.outcome.returned


def test_the_correction_needs_the_controllers_model_to_be_the_arms():
    scenario = load_scenario("default")
    scenario.controller.drive_aware = True
    scenario.controller.mass_scale = 1.2
    with pytest.raises(ScenarioError, match="drive_aware"):
        validate(scenario)
