"""A correction of the arm controller's torque for joints whose drives cannot give theirs.

The InverseDynamicsController computes every joint's torque from the commanded accelerations,

    tau = M(q) vd + h(q, v),   vd = q̈_d + kp (q_d - q) + kd (v_d - v)

(h: Coriolis, gravity and joint damping). When the drives clamp the torque of a set S of
joints (outside their bounds at the joints' speeds, :meth:`tt_drake.drives.DriveEnvelope.bounds`;
the effort limits with ideal drives), those joints accelerate as the clamped torques allow,

    a_S = M_SS^-1 (tau_S^c - h_S - M_SF vd_F),

while the other joints F still get the coupling torque of the commanded vd_S, which does not
happen: on the stock robot's fast backhand strokes the base's drive can only brake, and the
wrist, pushed by the coupling, runs past its position limit although its plan stays inside it
(docs/analytical_player.md, "Drives"). The torque that gives F its commanded accelerations with
S clamped is

    tau_F' = M_FS a_S + M_FF vd_F + h_F,

and a joint of F that tau_F' takes out of its bounds joins S at that bound (at most seven
rounds). The correction is tau_F' - tau_F on F, the bound less the command on the joints that
joined S, and zero on the joints the drives clamped from the start (they clamp them in any
case).

:class:`DriveAwareCorrection` evaluates it at the servo ticks from the arm's state and the
set-point the controller holds, and holds it for a tick (a discrete state, read by the torque's
C++ adder without a call into Python); while no joint is clamped it is zero and the state is not
written, so an episode in which no drive clamps is the controller's alone, to the bit. On with
``controller.drive_aware`` (docs/faults.md, "Drive-aware correction").
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake import wam_params as wp
from tt_drake.drives import DriveEnvelope, EffortBudget
from tt_drake.rnea import Chain

_NOTHING = EventStatus.DidNothing()


def clamped_correction(chain: Chain, bounds, q, v, vd) -> np.ndarray:
    """The correction of the module docstring for the acceleration command ``vd`` at the state
    (q, v): added to the command, the drives let through the torques that give the joints they
    do not clamp their commanded accelerations."""
    q, v, vd = (np.asarray(x, dtype=float) for x in (q, v, vd))
    tau = chain.torques(q, v, vd)
    lower, upper = bounds(v)
    first = (tau < lower) | (tau > upper)
    correction = np.zeros(len(q))
    if not first.any():
        return correction
    clamped = first.copy()
    n = len(q)
    h = chain.torques(q, v, np.zeros(n))
    M = chain.mass_matrix(q)
    wanted = tau.copy()
    for _ in range(n):
        free = ~clamped
        if not free.any():
            return correction
        torque_S = np.clip(wanted[clamped], lower[clamped], upper[clamped])
        a_S = np.linalg.solve(M[np.ix_(clamped, clamped)],
                              torque_S - h[clamped] - M[np.ix_(clamped, free)] @ vd[free])
        torque_F = M[np.ix_(free, clamped)] @ a_S + M[np.ix_(free, free)] @ vd[free] + h[free]
        wanted[free] = torque_F
        leaving = np.zeros(n, dtype=bool)
        leaving[free] = (torque_F < lower[free]) | (torque_F > upper[free])
        if not leaving.any():
            break
        clamped |= leaving
    # The joints that joined S get their bound; those the drives clamped from the start are
    # left to them (their command is not changed).
    final = np.where(clamped, np.clip(wanted, lower, upper), wanted)
    correction[~first] = final[~first] - tau[~first]
    return correction


class DriveAwareCorrection(LeafSystem):
    """Input ports ``state`` (the arm's q, v: 14), ``desired_state`` (14) and
    ``desired_acceleration`` (7), what the controller gets; output ``correction`` (7, N m), to
    be added to the controller's torque before the drives. Updated at the servo ticks
    (``period``, ticks at k * period, as the servo hold's)."""

    def __init__(self, chain: Chain, kp, kd, drive: DriveEnvelope | None,
                 period: float = wp.SERVO_PERIOD):
        super().__init__()
        self.chain = chain
        self.kp, self.kd = np.asarray(kp, dtype=float), np.asarray(kd, dtype=float)
        self.bounds = EffortBudget(1.0, drive).bounds  # the drives' and the effort limits
        self._state = self.DeclareVectorInputPort("state", 2 * wp.NUM_JOINTS)
        self._desired = self.DeclareVectorInputPort("desired_state", 2 * wp.NUM_JOINTS)
        self._acceleration = self.DeclareVectorInputPort("desired_acceleration", wp.NUM_JOINTS)
        self._correction = self.DeclareDiscreteState(wp.NUM_JOINTS)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareStateOutputPort("correction", self._correction)

    def _update(self, context, discrete_state):
        n = wp.NUM_JOINTS
        x = self._state.Eval(context)
        desired = self._desired.Eval(context)
        q, v = x[:n], x[n:]
        vd = (self._acceleration.Eval(context) + self.kp * (desired[:n] - q)
              + self.kd * (desired[n:] - v))
        correction = clamped_correction(self.chain, self.bounds, q, v, vd)
        if not correction.any() and not context.get_discrete_state(self._correction).value().any():
            return _NOTHING  # zero and still zero: nothing downstream is recomputed
        discrete_state.set_value(self._correction, correction)
