"""The numpy ball model against independent physics: ODE integration, impact theory, rolling."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tt_drake.ball_model import BallModel, BallModelParams, hunt_crossley_restitution
from tt_drake.constants import TABLE


def test_restitution_matches_first_order_theory_for_small_dissipation():
    # For small d v the Hunt-Crossley impact gives e ~ 1 - (2/3) d v (Hunt & Crossley 1975).
    for dv in (0.002, 0.005, 0.01):
        assert hunt_crossley_restitution(dv, 1.0) == pytest.approx(1 - 2 / 3 * dv, abs=2e-4)


def test_restitution_decreases_with_impact_speed_and_matches_drake_measurements():
    # Drake measurements (docs/constants.md) for a surface of k = 1e5 N/m, stiff ball.
    measured = {(0.04, 2.0): 0.949, (0.06, 4.0): 0.862, (0.08, 2.43): 0.884, (0.04, 8.0): 0.825}
    for (d, v), e in measured.items():
        assert hunt_crossley_restitution(d, v) == pytest.approx(e, abs=0.003)
    speeds = np.linspace(0.5, 10, 20)
    es = [hunt_crossley_restitution(0.064, v) for v in speeds]
    assert np.all(np.diff(es) < 0)


def _reference_flight(state, duration, k, cl, g=9.81):
    def f(_t, s):
        v, w = s[3:6], s[6:9]
        a = -k * np.linalg.norm(v) * v + cl * np.cross(w, v) + np.array([0, 0, -g])
        return np.r_[v, a, np.zeros(3)]

    sol = solve_ivp(f, (0, duration), state, rtol=1e-11, atol=1e-12)
    return sol.y[:, -1]


def test_flight_matches_a_high_accuracy_ode_solution_with_drag_and_magnus():
    model = BallModel(dt=2e-3)
    state = np.array([0.1, 1.5, 1.2, -0.5, -5.0, 1.0, 30.0, -80.0, 20.0])
    out = model.predict_time(state, 0.25)  # stays in the air: no bounce
    ref = _reference_flight(state, 0.25, model.params.drag_k, model.params.magnus_cl)
    assert not out.bounces
    np.testing.assert_allclose(out.position, ref[0:3], atol=1e-8)
    np.testing.assert_allclose(out.velocity, ref[3:6], atol=1e-7)


def test_drag_free_flight_is_a_parabola():
    model = BallModel(BallModelParams(drag_k=0.0, magnus_cl=0.0))
    state = np.array([0.0, 1.0, 1.5, 0.3, -4.0, 0.5, 0, 0, 0])
    t = 0.3
    out = model.predict_time(state, t)
    expected = state[0:3] + state[3:6] * t + 0.5 * np.array([0, 0, -9.81]) * t * t
    np.testing.assert_allclose(out.position, expected, atol=1e-12)


def test_vertical_bounce_keeps_horizontal_velocity_and_scales_normal_speed():
    model = BallModel()
    v_in = (0.0, 0.0, -3.0)
    v_out, w_out = model.bounce(v_in, (0.0, 0.0, 0.0))
    assert v_out[2] == pytest.approx(3.0 * model.table_restitution(3.0))
    assert v_out[0] == v_out[1] == 0.0 and w_out == (0.0, 0.0, 0.0)


def test_grazing_bounce_reaches_the_rolling_limit_of_a_hollow_sphere():
    # Shallow impact with high friction: the contact point stops slipping, so
    # v_t' = 0.6 v_t + 0.4 omega R (thin hollow sphere, I = 2/3 m R^2), and it then rolls.
    model = BallModel(BallModelParams(table_friction=1.0))
    r = model.params.radius
    v_out, w_out = model.bounce((0.0, 2.0, -1.0), (10.0, 0.0, 0.0))
    # omega_x = 10 rad/s about +x; for motion along +y, rolling needs v_y = -omega_x R.
    assert v_out[1] == pytest.approx(0.6 * 2.0 - 0.4 * 10.0 * r)
    assert v_out[1] + r * w_out[0] == pytest.approx(0.0, abs=1e-12)


def test_sliding_bounce_loses_mu_times_normal_impulse():
    model = BallModel(BallModelParams(table_friction=0.1))
    v_out, _ = model.bounce((0.0, 5.0, -2.0), (0.0, 0.0, 0.0))
    e = model.table_restitution(2.0)
    assert v_out[1] == pytest.approx(5.0 - 0.1 * (1 + e) * 2.0)


def test_predict_plane_goes_through_the_bounce():
    model = BallModel()
    state = np.array([0.0, 1.5, 0.9, 0.0, -5.0, 2.5, 0, 0, 0])
    crossing = model.predict_plane(state, -1.8)
    assert crossing is not None and len(crossing.bounces) == 1
    assert crossing.position[1] == pytest.approx(-1.8, abs=1e-9)
    assert crossing.bounces[0].position[2] == pytest.approx(TABLE.surface_z + 0.02, abs=1e-6)


def test_bad_state_is_rejected():
    model = BallModel()
    with pytest.raises(ValueError, match="6 or 9"):
        model.predict_plane(np.zeros(4), 0.0)
    with pytest.raises(ValueError, match="NaN"):
        model.predict_plane(np.array([0, 0, 1, math.nan, 0, 0]), 0.0)


def test_predict_time_lands_exactly_on_the_requested_time():
    # Times between integrator steps must be hit exactly, not rounded to the next step.
    model = BallModel(dt=0.01)
    state = np.array([0.0, 1.0, 1.5, 0.3, -4.0, 0.5, 0, 0, 0])
    for t in (0.0123, 0.2071, 0.333):
        out = model.predict_time(state, t)
        assert out.t == pytest.approx(t, abs=1e-9)
        fine = BallModel(dt=1e-4).predict_time(state, t)
        np.testing.assert_allclose(out.position, fine.position, atol=1e-7)


def test_flight_step_variational_is_the_derivative_of_the_rk4_step():
    # Same state as flight_step to the last bit; sensitivities to the initial velocity equal
    # central differences of the step (with spin, so the Magnus term of the Jacobian counts).
    model = BallModel()
    rng = np.random.default_rng(7)
    identity, zero = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0,) * 9
    for _ in range(20):
        pos, vel = tuple(rng.uniform(-2, 2, 3)), tuple(rng.uniform(-8, 8, 3))
        w, h = tuple(rng.uniform(-200, 200, 3)), rng.uniform(1e-4, 8e-3)
        new_p, new_v, dp, dv = model.flight_step_variational(pos, vel, w, h, zero, identity)
        assert (new_p, new_v) == model.flight_step(pos, vel, w, h)
        fd = np.empty((6, 3))
        for j in range(3):
            e = np.eye(3)[j] * 1e-5
            hi = model.flight_step(pos, tuple(vel + e), w, h)
            lo = model.flight_step(pos, tuple(vel - e), w, h)
            fd[:, j] = (np.r_[hi[0], hi[1]] - np.r_[lo[0], lo[1]]) / 2e-5
        np.testing.assert_allclose(np.r_[np.reshape(dp, (3, 3)), np.reshape(dv, (3, 3))], fd,
                                   atol=1e-9)


def test_locate_finds_the_crossing_to_bisection_accuracy():
    # The root finder against a 60-halving bisection of the same event, inside [0, h].
    model = BallModel()
    rng = np.random.default_rng(3)
    for _ in range(50):
        pos, vel = (0.0, 0.0, 1.0), tuple(rng.uniform([-1, -8, -3], [1, -3, 3]))
        w, h = tuple(rng.uniform(-100, 100, 3)), 8e-3
        plane = rng.uniform(0.02, 0.98) * model.flight_step(pos, vel, w, h)[0][1]

        def g(_s, q, _v, plane=plane):
            return q[1] - plane

        s = model._locate(pos, vel, w, h, g)
        lo, hi = 0.0, h
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if g(mid, *model.flight_step(pos, vel, w, mid)) > 0.0:
                lo = mid
            else:
                hi = mid
        assert 0.0 <= s <= h
        assert s == pytest.approx(0.5 * (lo + hi), abs=1e-13)


def test_locate_without_a_sign_change_bisects_as_before():
    model = BallModel()
    pos, vel, w = (0.0, 0.0, 1.0), (0.0, -5.0, 1.0), (0.0, 0.0, 0.0)

    def g(_s, q, _v):
        return q[1] + 1.0  # positive over the whole step

    assert model._locate(pos, vel, w, 5e-3, g) == model._bisect(pos, vel, w, 5e-3, g)


def test_first_bounce_is_the_closed_form_landing_of_a_ball_in_vacuum():
    # No drag, no Magnus: the centre reaches table_z + R at t = (vz + sqrt(vz^2 + 2 g dz)) / g.
    model = BallModel(BallModelParams(drag_k=0.0, magnus_cl=0.0))
    p0, v0 = np.array([0.1, 0.8, 1.1]), np.array([0.3, -2.0, 1.5])
    bounce = model.first_bounce(np.r_[p0, v0, 0.0, 0.0, 0.0])
    g, dz = model.params.gravity, p0[2] - (model.params.table_z + model.params.radius)
    t = (v0[2] + math.sqrt(v0[2] ** 2 + 2 * g * dz)) / g
    assert bounce.t == pytest.approx(t, abs=1e-9)
    np.testing.assert_allclose(bounce.position[:2], p0[:2] + v0[:2] * t, atol=1e-8)
    # The same impact the predictions record on their way, and none off the table.
    later = model.predict_time(np.r_[p0, v0], t + 0.05)
    assert later.bounces[0] == bounce
    assert model.first_bounce(np.r_[0.0, 0.8, 1.1, 3.0, 0.0, 0.0]) is None
