"""The compiled flight kernel: the RK4 arithmetic of the Python ball model to the last bit, a
fourth-order integrator, and compiled without a disk cache where none can be written."""

import numpy as np
import pytest

from tt_drake import flight_kernel
from tt_drake.ball_model import BallModel

MODEL = BallModel()


def _random_flights(n: int, seed: int = 0, backward: bool = True):
    """Ball states and steps (forward, and with ``backward`` also negative: the bounce test
    follows the flight back in time)."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        pos = tuple(rng.normal(0.0, 1.0, 3).tolist())
        vel = tuple(rng.normal(0.0, 6.0, 3).tolist())
        spin = tuple(rng.normal(0.0, 120.0, 3).tolist())
        sign = rng.choice([-1.0, 1.0]) if backward else 1.0
        yield pos, vel, spin, float(rng.uniform(1e-4, 0.02)) * sign


def test_a_compiled_step_is_the_python_floats_rk4_step_to_the_last_bit():
    """``rk4_stages`` does the step in Python floats through ``acceleration`` (the estimator's
    variational steps use it); the compiled step must give the same floats, not close ones:
    every prediction's outcome is compared bit for bit across levers."""
    for pos, vel, spin, h in _random_flights(400):
        _, p_python, v_python = MODEL.rk4_stages(pos, vel, spin, h)
        assert MODEL.flight_step(pos, vel, spin, h) == (p_python, v_python)


def test_many_steps_in_one_call_are_the_single_steps_in_turn():
    for pos, vel, spin, h in _random_flights(50, seed=1, backward=False):
        p, v = pos, vel
        for _ in range(37):
            p, v = MODEL.flight_step(p, v, spin, h)
        assert np.all(np.isfinite(p + v))
        assert MODEL.fly(pos, vel, spin, h, 37) == (p, v)
    # Zero steps leave the state as it is.
    assert MODEL.fly((0.1, 0.2, 0.3), (1.0, 2.0, 3.0), (0.0, 0.0, 0.0), 0.01, 0) == (
        (0.1, 0.2, 0.3), (1.0, 2.0, 3.0))


def test_the_kernel_integrates_drag_and_magnus_to_fourth_order():
    """The error after 0.5 s against a 1e-5 s solution falls ~16x when the step halves (RK4's
    global error O(h^4)), for a fast spinning ball (drag and Magnus both matter)."""
    pos, vel, spin = (0.0, 1.2, 0.3), (0.5, -7.0, 2.0), (40.0, -150.0, 30.0)
    exact = np.array(MODEL.fly(pos, vel, spin, 1e-5, 50_000)[0])
    errors = [np.linalg.norm(np.array(MODEL.fly(pos, vel, spin, 0.5 / n, n)[0]) - exact)
              for n in (10, 20, 40)]
    assert 12.0 < errors[0] / errors[1] < 20.0
    assert 12.0 < errors[1] / errors[2] < 20.0


def test_the_step_is_the_flight_equations_acceleration():
    """(v+ - v) / h tends to g - k |v| v + C_L (omega x v) as h -> 0."""
    p = MODEL.params
    vel, spin = np.array([1.0, -6.0, 2.0]), np.array([20.0, 80.0, -50.0])
    h = 1e-7
    _, v_new = MODEL.flight_step((0.0, 0.0, 0.5), tuple(vel), tuple(spin), h)
    expected = (np.array([0.0, 0.0, -p.gravity]) - p.drag_k * np.linalg.norm(vel) * vel
                + p.magnus_cl * np.cross(spin, vel))
    assert np.allclose((np.array(v_new) - vel) / h, expected, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("error", [RuntimeError("cannot cache function: no locator available"),
                                   OSError(27, "File too large")])
def test_without_a_writable_cache_the_kernel_compiles_in_memory(monkeypatch, error):
    """numba raises RuntimeError at ``cache=True`` when neither the install nor the user's cache
    directory can be written (a read-only install), and OSError when the cache file cannot be
    written (a full disk): the kernel is then compiled without the disk cache, and computes the
    same numbers."""
    real_njit = flight_kernel.njit
    asked = []

    def njit_without_cache(*args, **kwargs):
        asked.append(kwargs.get("cache", False))
        if kwargs.get("cache"):
            raise error
        return real_njit(*args, **kwargs)

    monkeypatch.setattr(flight_kernel, "njit", njit_without_cache)
    kernel = flight_kernel.compiled(flight_kernel.SIGNATURE)(flight_kernel.rk4_flight.py_func)
    assert asked == [True, False]
    args = (0.1, 1.2, 0.9, 0.3, -6.0, 1.0, 10.0, -90.0, 5.0, MODEL.params.drag_k,
            MODEL.params.magnus_cl, MODEL.params.gravity, 0.01, 25)
    assert kernel(*args) == flight_kernel.rk4_flight(*args)


def test_the_kernel_converts_what_it_is_given_to_its_declared_types():
    """Integers and numpy scalars are converted to the declared float64 arguments; a
    non-number is refused."""
    a = flight_kernel.rk4_flight(0, 1, 1, 0, -5, 1, 0, 0, 0, 0.1, 0.2, 9.81, 0.01, 3)
    b = flight_kernel.rk4_flight(*(float(x) for x in (0, 1, 1, 0, -5, 1, 0, 0, 0)),
                                 np.float64(0.1), 0.2, 9.81, 0.01, np.int64(3))
    assert a == b
    with pytest.raises(TypeError):
        flight_kernel.rk4_flight("0", 1, 1, 0, -5, 1, 0, 0, 0, 0.1, 0.2, 9.81, 0.01, 3)


def _states(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield np.r_[rng.uniform(-0.8, 0.8), rng.uniform(-1.4, 1.6), rng.uniform(0.8, 1.3),
                    rng.normal(0.0, 1.0), rng.uniform(-8.0, 2.0), rng.normal(0.0, 2.5),
                    rng.normal(0.0, 120.0, 3)]


DURATION = 0.37  # s: predict_time's stop in the test below


def test_the_compiled_flight_between_bounces_is_advances_python_loop_to_the_bit():
    """``advance`` with a compiled stop (a plane, a time, none) gives what its step-by-step Python
    loop gives for the same stop function: the same event state, time and bounces, or None."""
    from tt_drake.flight_kernel import STOP_NEVER, STOP_PLANE, STOP_TIME

    kinds = 0
    for state in _states(300, 7):
        cases = []
        for plane in (-1.82, 0.0):
            side = 1.0 if state[1] > plane else -1.0

            def stop(_t, q, _v, plane=plane, side=side):
                return side * (q[1] - plane)

            cases.append((stop, (STOP_PLANE, plane, side), False))
        def at_time(t, _q, _v):
            return DURATION - t

        cases += [(at_time, (STOP_TIME, DURATION, 0.0), False),
                  (lambda _t, _q, _v: 1.0, (STOP_NEVER, 0.0, 0.0), True)]
        for stop_fn, event, until_bounce in cases:
            slow = MODEL.advance(state, stop_fn, 2.0, until_bounce=until_bounce)
            fast = MODEL.advance(state, None, 2.0, until_bounce=until_bounce, event=event)
            if slow is None or fast is None:
                assert slow is None and fast is None
                continue
            kinds += 1
            if until_bounce:
                assert (fast.t, tuple(fast.position)) == (slow.t, tuple(slow.position))
            else:
                assert fast.t == slow.t and len(fast.bounces) == len(slow.bounces)
                np.testing.assert_array_equal(fast.state, slow.state)
    assert kinds > 600  # most of the flights end at their event
