"""The arm's compiled recursive Newton-Euler inverse dynamics (tt_drake/rnea.py, read off the plant
by systems/arm_dynamics.py): Drake's inverse dynamics of the arm to
rounding, a pendulum's equation of motion, one sample as a batch of one."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    MultibodyForces,
    PrismaticJoint,
    RevoluteJoint,
    SpatialInertia,
    UnitInertia,
)

from tt_drake.systems.arm_dynamics import chain_of
from tt_drake.systems.wam import make_control_plant


def _drake_torques(plant, context, q, v, a):
    """M(q) a + C(q, v) v - tau_g(q) by Drake: the force elements (gravity) applied."""
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    forces = MultibodyForces(plant)
    plant.CalcForceElementsContribution(context, forces)
    return plant.CalcInverseDynamics(context, a, forces)


def _point_mass(mass: float, position) -> SpatialInertia:
    """A point mass at ``position`` in its body's frame, about the body's origin."""
    return SpatialInertia(mass, position, UnitInertia.PointMass(position))


def test_the_arms_chain_gives_drakes_inverse_dynamics():
    plant = make_control_plant()
    context = plant.CreateDefaultContext()
    chain = chain_of(plant)
    rng = np.random.default_rng(4)
    Q = rng.uniform(-2.5, 2.5, (60, 7))
    V = rng.normal(0.0, 4.0, (60, 7))
    A = rng.normal(0.0, 40.0, (60, 7))
    expected = np.array([_drake_torques(plant, context, *x) for x in zip(Q, V, A, strict=True)])
    tau = chain.torques(Q, V, A)
    assert tau.shape == (60, 7)
    assert np.abs(expected).max() > 50.0  # the states ask for real torques
    np.testing.assert_allclose(tau, expected, rtol=0.0, atol=1e-9)
    # One sample as (7,) arrays is the batch's row.
    np.testing.assert_array_equal(chain.torques(Q[3], V[3], A[3]), tau[3])
    # Read-only samples (a Drake log's data is a read-only view) give the same torques.
    frozen = [x.copy() for x in (Q, V, A)]
    for x in frozen:
        x.flags.writeable = False
    np.testing.assert_array_equal(chain.torques(*frozen), tau)
    np.testing.assert_array_equal(chain.torques(*(x[3] for x in frozen)), tau[3])


def test_the_chains_mass_matrix_is_drakes():
    plant = make_control_plant()
    context = plant.CreateDefaultContext()
    chain = chain_of(plant)
    rng = np.random.default_rng(5)
    for q in rng.uniform(-2.5, 2.5, (20, 7)):
        plant.SetPositions(context, q)
        M = chain.mass_matrix(q)
        np.testing.assert_allclose(M, plant.CalcMassMatrix(context), rtol=0.0, atol=1e-9)
        np.testing.assert_allclose(M, M.T, rtol=0.0, atol=1e-12)


def test_a_pendulum_obeys_its_equation_of_motion():
    """tau = m l^2 q_ddot + m g l sin(q) + d q_dot for a point mass m at distance l."""
    m, l, g, d = 2.0, 0.5, 9.81, 0.3
    plant = MultibodyPlant(0.0)
    body = plant.AddRigidBody("bob", _point_mass(m, [0.0, 0.0, -l]))
    plant.AddJoint(RevoluteJoint("hinge", plant.world_frame(), body.body_frame(),
                                 [1.0, 0.0, 0.0], d))
    plant.Finalize()
    chain = chain_of(plant)
    q = np.array([[0.0], [0.4], [-1.2], [2.0]])
    qd = np.array([[0.0], [1.5], [-2.0], [0.7]])
    qdd = np.array([[1.0], [-3.0], [0.5], [0.0]])
    expected = m * l * l * qdd + m * g * l * np.sin(q) + d * qd
    np.testing.assert_allclose(chain.torques(q, qd, qdd), expected, rtol=1e-12, atol=1e-12)


def test_a_joint_the_chain_does_not_hold_is_refused():
    plant = MultibodyPlant(0.0)
    body = plant.AddRigidBody("slider", _point_mass(1.0, [0.0, 0.0, 0.0]))
    plant.AddJoint(PrismaticJoint("slide", plant.world_frame(), body.body_frame(),
                                  [1.0, 0.0, 0.0]))
    plant.Finalize()
    with pytest.raises(ValueError, match="revolute and weld joints only"):
        chain_of(plant)


def test_a_base_off_the_origin_and_a_weld_carry_the_wrench():
    """A body welded to a pendulum's bob, the hinge away from the world origin: the torque is
    the pendulum's with both masses, and does not depend on where the hinge stands."""
    g = 9.81
    plants = []
    for origin in ([0.0, 0.0, 0.0], [0.3, -0.2, 1.0]):
        plant = MultibodyPlant(0.0)
        bob = plant.AddRigidBody("bob", _point_mass(1.0, [0.0, 0.0, -0.4]))
        tip = plant.AddRigidBody("tip", _point_mass(0.5, [0.0, 0.0, 0.0]))
        frame = plant.AddFrame(FixedOffsetFrame("hinge_frame", plant.world_frame(),
                                                RigidTransform(origin)))
        plant.AddJoint(RevoluteJoint("hinge", frame, bob.body_frame(), [1.0, 0.0, 0.0]))
        plant.WeldFrames(bob.body_frame(), tip.body_frame(), RigidTransform([0.0, 0.0, -0.8]))
        plant.Finalize()
        plants.append(plant)
    q, qd, qdd = np.array([[0.7]]), np.array([[1.1]]), np.array([[-2.0]])
    expected = (1.0 * 0.4**2 + 0.5 * 0.8**2) * qdd + (1.0 * 0.4 + 0.5 * 0.8) * g * np.sin(q)
    for plant in plants:
        np.testing.assert_allclose(chain_of(plant).torques(q, qd, qdd), expected, rtol=1e-12)
