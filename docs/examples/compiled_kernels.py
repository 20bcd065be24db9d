"""CPU per call of the compiled ball flight, inverse dynamics and quintic segments against the
arithmetic they replace, and their agreement (docs/performance.md, "Compiled arithmetic").

    OPENBLAS_NUM_THREADS=1 python docs/examples/compiled_kernels.py [--repeats 2000]

- a flight step: ``BallModel.flight_step`` (compiled) against ``BallModel.rk4_stages`` (the same
  RK4 step in Python floats), and a 25-step flight (``BallModel.fly``) against 25 such steps;
- the backward bounce test (``hitting_time.last_robot_bounce``) against its loop of Python-float
  steps, on 200 states of balls on the robot's half;
- the arm's inverse dynamics for a 50-sample plan segment: ``HittingIK.torques`` (compiled RNEA,
  all samples in one call) against Drake's ``CalcInverseDynamics`` per sample;
- a quintic segment at 81 times and at one (``Quintic.evaluate_many``, ``Quintic.evaluate``:
  compiled) against its numpy array expressions (``quintic_many_numpy``);
- the racket's restitution (``racket_law.racket_restitution``: the compiled table lookup
  ``interp_one``) against ``numpy.interp`` on the same table;
- the teacher's net clearance (``racket_law.net_clearance``: the compiled net crossing) against
  its loop of 10 ms flight steps;
- the estimator's prediction noise (``add_process_noise``) against ``M = P + Q; (M + M^T) / 2``
  in numpy.

Each pair is checked: the flights, the bounce times, the quintic's values, the restitutions,
the clearances and the covariances must be equal to the bit, the torques within 1e-9 N m; the
script exits with status 1 otherwise.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from pydrake.multibody.tree import MultibodyForces

from tt_drake.ball_model import BallModel, restitution_table
from tt_drake.constants import BALL, NET, TABLE
from tt_drake.estimation import N_STATE, BallFlightEKF
from tt_drake.filter_kernel import add_process_noise
from tt_drake.hitting_time import last_robot_bounce
from tt_drake.quintic_kernel import quintic_many_numpy
from tt_drake.racket_law import HELD_RACKET_DISSIPATION, net_clearance, racket_restitution
from tt_drake.stages import Quintic
from tt_drake.systems.hitting_ik import HittingIK


def _cpu_us(fn, repeats: int) -> float:
    c0 = time.process_time()
    for _ in range(repeats):
        fn()
    return 1e6 * (time.process_time() - c0) / repeats


def _python_flight(model: BallModel, pos, vel, w, h: float, steps: int):
    for _ in range(steps):
        _, pos, vel = model.rk4_stages(pos, vel, w, h)
    return pos, vel


def _python_backward(model: BallModel, state, step: float, max_time: float = 1.0):
    """last_robot_bounce's loop in Python floats."""
    p = model.params
    contact_z = p.table_z + p.radius
    pos, vel, w = tuple(state[0:3]), tuple(state[3:6]), tuple(state[6:9])
    t = 0.0
    while t < max_time:
        pos, vel = _python_flight(model, pos, vel, w, -step, 1)
        t += step
        if pos[1] >= 0.0:
            return None
        if pos[2] <= contact_z and model.over_table(pos[0], pos[1]):
            return t
    return None


def _python_clearance(model: BallModel, pos, vel, w):
    """net_clearance's loop of 10 ms Python-level steps."""
    contact_z = TABLE.surface_z + BALL.radius
    for _ in range(200):
        new_p, new_v = model.flight_step(pos, vel, w, 0.01)
        if new_p[1] >= 0.0 > pos[1]:
            s = -pos[1] / (new_p[1] - pos[1])
            return pos[2] + s * (new_p[2] - pos[2]) - BALL.radius - (TABLE.surface_z + NET.height)
        if new_p[2] < contact_z:
            return -np.inf
        pos, vel = new_p, new_v
    return -np.inf


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=2000)
    args = ap.parse_args(argv)
    n = max(1, args.repeats)
    model = BallModel()
    pos, vel, w = (0.1, 1.2, 0.9), (0.3, -6.0, 1.0), (10.0, -90.0, 5.0)
    ok = True

    same = model.flight_step(pos, vel, w, 0.01) == model.rk4_stages(pos, vel, w, 0.01)[1:]
    same &= model.fly(pos, vel, w, 0.02, 25) == _python_flight(model, pos, vel, w, 0.02, 25)
    step_py = _cpu_us(lambda: model.rk4_stages(pos, vel, w, 0.01), n)
    step_c = _cpu_us(lambda: model.flight_step(pos, vel, w, 0.01), n)
    fly_py = _cpu_us(lambda: _python_flight(model, pos, vel, w, 0.02, 25), max(1, n // 10))
    fly_c = _cpu_us(lambda: model.fly(pos, vel, w, 0.02, 25), n)
    print(f"flight step: Python floats {step_py:.2f} us, compiled {step_c:.2f} us; 25 steps: "
          f"{fly_py:.1f} us, {fly_c:.2f} us; equal to the bit: {same}")
    ok &= same

    rng = np.random.default_rng(0)
    states = [np.r_[rng.uniform(-0.7, 0.7), rng.uniform(-1.5, -0.05), rng.uniform(0.8, 1.2),
                    rng.normal(0.0, 1.0), rng.uniform(-7.0, -2.0), rng.normal(0.0, 3.0),
                    rng.normal(0.0, 80.0, 3)] for _ in range(200)]
    states = [s.tolist() for s in states]
    same = all(last_robot_bounce(model, s, step=0.002) == _python_backward(model, s, 0.002)
               for s in states)
    reps = max(1, n // 200)
    back_py = _cpu_us(lambda: [_python_backward(model, s, 0.002) for s in states], reps) / 200
    back_c = _cpu_us(lambda: [last_robot_bounce(model, s, step=0.002) for s in states],
                     reps) / 200
    print(f"backward bounce test (2 ms steps): Python floats {back_py:.1f} us, compiled "
          f"{back_c:.1f} us per state; the same answers: {same}")
    ok &= same

    ik = HittingIK()
    plant, context = ik.plant, ik.plant.CreateDefaultContext()
    forces = MultibodyForces(plant)
    Q = rng.uniform(-2.0, 2.0, (50, 7))
    V = rng.normal(0.0, 3.0, (50, 7))
    A = rng.normal(0.0, 30.0, (50, 7))

    def drake_per_sample():
        out = np.empty((50, 7))
        for i in range(50):
            plant.SetPositionsAndVelocities(context, np.concatenate((Q[i], V[i])))
            plant.CalcForceElementsContribution(context, forces)
            out[i] = plant.CalcInverseDynamics(context, A[i], forces)
        return out

    gap = float(np.abs(ik.torques(Q, V, A) - drake_per_sample()).max())
    reps = max(1, n // 20)
    id_drake = _cpu_us(drake_per_sample, reps) / 50
    id_c = _cpu_us(lambda: ik.torques(Q, V, A), reps) / 50
    print(f"inverse dynamics, 50 samples: Drake per sample {id_drake:.2f} us, compiled RNEA "
          f"{id_c:.2f} us per sample; largest difference {gap:.1e} N m")
    ok &= gap <= 1e-9

    segment = Quintic.fit(0.1, 0.4, *rng.normal(size=(6, 7)))
    times = np.linspace(0.1, 0.5, 81)

    def numpy_values(at):
        return quintic_many_numpy(segment.coeffs, segment.t0, segment.duration, at)

    one = np.array([0.3])
    same = all(np.array_equal(x, y) for x, y in zip(segment.evaluate_many(times),
                                                     numpy_values(times), strict=True))
    same &= all(np.array_equal(x, y[0]) for x, y in zip(segment.evaluate(0.3),
                                                        numpy_values(one), strict=True))
    many_np = _cpu_us(lambda: numpy_values(times), n)
    many_c = _cpu_us(lambda: segment.evaluate_many(times), n)
    one_np = _cpu_us(lambda: numpy_values(one), n)
    one_c = _cpu_us(lambda: segment.evaluate(0.3), n)
    print(f"quintic segment, 81 times: numpy {many_np:.1f} us, compiled {many_c:.1f} us; one "
          f"time: numpy {one_np:.1f} us, compiled {one_c:.1f} us; equal to the bit: {same}")
    ok &= same

    dv, e = restitution_table()
    speeds = rng.uniform(0.0, 30.0, 200).tolist()

    def numpy_restitution():
        return [float(np.interp(HELD_RACKET_DISSIPATION * abs(v), dv, e)) for v in speeds]

    same = [racket_restitution(v) for v in speeds] == numpy_restitution()
    interp_np = _cpu_us(numpy_restitution, max(1, n // 20)) / 200
    interp_c = _cpu_us(lambda: [racket_restitution(v) for v in speeds], max(1, n // 20)) / 200
    print(f"racket restitution: numpy.interp {interp_np:.2f} us, compiled {interp_c:.2f} us; "
          f"equal to the bit: {same}")
    ok &= same

    start, out = (0.1, -1.6, 1.0), (-0.2, 5.0, 1.5)
    same = net_clearance(model, start, out, w) == _python_clearance(model, start, out, w)
    clear_py = _cpu_us(lambda: _python_clearance(model, start, out, w), n)
    clear_c = _cpu_us(lambda: net_clearance(model, start, out, w), n)
    print(f"net clearance: Python steps {clear_py:.1f} us, compiled {clear_c:.1f} us; equal to "
          f"the bit: {same}")
    ok &= same

    ekf = BallFlightEKF()
    P = rng.normal(0.0, 1.0, (N_STATE, N_STATE))
    P_out = np.empty((N_STATE, N_STATE))

    pp, pv, vv, ww = ekf.noise_terms(1 / 60, False)
    i3 = np.eye(3)

    def numpy_noise():
        Q = np.zeros((N_STATE, N_STATE))
        Q[:3, :3] = pp * i3
        Q[:3, 3:6] = Q[3:6, :3] = pv * i3
        Q[3:6, 3:6] = vv * i3
        Q[6:9, 6:9] = ww * i3
        M = P + Q
        return 0.5 * (M + M.T)

    add_process_noise(P, *ekf.noise_terms(1 / 60, False), P_out)
    same = bool(np.array_equal(P_out, numpy_noise()))
    noise_np = _cpu_us(numpy_noise, n)
    noise_c = _cpu_us(lambda: add_process_noise(P, *ekf.noise_terms(1 / 60, False), P_out), n)
    print(f"prediction noise: numpy {noise_np:.1f} us, compiled {noise_c:.1f} us; equal to the "
          f"bit: {same}")
    ok &= same
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
