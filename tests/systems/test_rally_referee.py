"""The rally referee on scripted rallies: ball paths flown by the numpy ball model, with the
strokes of scripted players (a velocity set at a point), fed through the system's ports."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import TABLE
from tt_drake.racket_law import solve_outgoing_velocity
from tt_drake.rally_rules import RallyConfig, to_side
from tt_drake.systems.rally_referee import RallyReferee

RATE = 250.0
DT = 1.0 / RATE
MODEL = BallModel()
SERVE = np.array([0.3, 1.57, 0.91, 0.0, -5.2, 3.0])  # bounces on A's half near y = -0.95


def state13(p, v, w=(0.0, 0.0, 0.0)):
    return np.r_[1.0, 0.0, 0.0, 0.0, p, w, v]


class Script:
    """A ball path sampled at the referee's rate: flights of the ball model, joined by strokes
    (the velocity replaced at a sample) or scripted contacts."""

    def __init__(self, p, v):
        self.t, self.p, self.v = 0.0, np.asarray(p, float), np.asarray(v, float)
        self.samples = [(0.0, self.p.copy(), self.v.copy())]
        self.incoming = []  # the ball's speed at each stroke

    def _step(self) -> bool:
        try:
            c = MODEL.predict_time(np.r_[self.p, self.v, 0.0, 0.0, 0.0], DT)
        except ValueError:  # the floor: one sample there, and the path ends
            self.t += DT
            self.samples.append((self.t, np.r_[self.p[:2], 0.02], self.v.copy()))
            return False
        self.t += DT
        self.p, self.v = c.position.copy(), c.velocity.copy()
        self.samples.append((self.t, self.p.copy(), self.v.copy()))
        return True

    def fly(self, seconds: float):
        for _ in range(round(seconds / DT)):
            if not self._step():
                break
        return self

    def fly_until(self, condition, limit: float = 3.0):
        for _ in range(round(limit / DT)):
            if condition(self.p, self.v) or not self._step():
                break
        return self

    def strike(self, v):
        """A scripted player's stroke: the ball leaves this point at ``v``."""
        self.incoming.append(float(np.linalg.norm(self.v)))
        self.v = np.asarray(v, dtype=float)
        return self

    def aim(self, goal_xy, flight_time: float = 0.6):
        """A stroke landing the ball at ``goal_xy`` (world frame) after ``flight_time``."""
        goal = (goal_xy[0], goal_xy[1], TABLE.surface_z + MODEL.params.radius)
        return self.strike(solve_outgoing_velocity(self.p, goal, flight_time, MODEL))


def crossing(side: int, y: float = 1.6):
    """The ball reached side ``side``'s striking line (world |y| = 1.6), coming to it."""
    sign = -1.0 if side == 0 else 1.0
    return lambda p, v: sign * p[1] > y and sign * v[1] > 0.0


def run(script: Script, config: RallyConfig | None = None):
    referee = RallyReferee(config or RallyConfig(), rate=RATE)
    context = referee.CreateDefaultContext()
    for port in ("robot_a_state", "robot_b_state"):
        referee.GetInputPort(port).FixValue(context, np.zeros(14))
    for t, p, v in script.samples:
        context.SetTime(t)
        referee.GetInputPort("ball_state").FixValue(context, state13(p, v))
        referee.ExecuteForcedEvents(context)
        if referee.record(context).over:
            break
    return referee.record(context)


def a_returns(script: Script, goal=(-0.3, 0.9)) -> Script:
    return script.fly_until(crossing(0)).aim(goal)


def test_a_legal_return_is_an_exchange_and_then_b_misses():
    record = run(a_returns(Script(SERVE[:3], SERVE[3:])).fly(3.0))
    assert [e.player for e in record.exchanges] == [0]
    # The landing, in A's frame, where the stroke aimed (the same flight law).
    np.testing.assert_allclose(record.exchanges[0].landing, (-0.3, 0.9), atol=0.03)
    assert record.over and not record.capped
    assert (record.fault.player, record.fault.kind) == (1, "missed")


def test_strokes_alternate_sides_and_the_cap_ends_the_rally():
    s = a_returns(Script(SERVE[:3], SERVE[3:]))
    s.fly_until(crossing(1)).aim((0.3, -0.9))  # B aims at (-0.3, 0.9) in its own frame
    s.fly_until(crossing(0)).aim((-0.2, 0.8))
    s.fly(3.0)
    record = run(s, RallyConfig(max_exchanges=3))
    assert [e.player for e in record.exchanges] == [0, 1, 0]
    assert record.capped and record.over and record.fault is None
    # Each landing is in its striker's frame: on the opponent's half, y > 0.
    np.testing.assert_allclose(record.exchanges[1].landing, to_side(1, 0.3, -0.9, 0)[:2],
                               atol=0.03)
    np.testing.assert_allclose(record.exchanges[2].landing, (-0.2, 0.8), atol=0.03)
    # What each striker had to return: the ball's speed at the last sample before its stroke.
    np.testing.assert_allclose([e.incoming_speed for e in record.exchanges], s.incoming,
                               rtol=1e-9)


def test_the_cap_is_not_reached_before_it():
    s = a_returns(Script(SERVE[:3], SERVE[3:]))
    s.fly_until(crossing(1)).aim((0.3, -0.9))
    s.fly(3.0)
    record = run(s, RallyConfig(max_exchanges=3))
    assert len(record.exchanges) == 2 and not record.capped
    assert (record.fault.player, record.fault.kind) == (0, "missed")


@pytest.mark.parametrize("goal, kind", [((0.0, -0.5), "own_half"), ((0.0, 2.2), "out")])
def test_a_return_that_does_not_land_on_the_other_half(goal, kind):
    s = Script(SERVE[:3], SERVE[3:]).fly_until(crossing(0)).aim(goal, 0.5).fly(3.0)
    record = run(s)
    assert record.exchanges == ()
    assert (record.fault.player, record.fault.kind) == (0, kind)


def test_a_ball_into_the_net_is_a_net_fault():
    s = Script(SERVE[:3], SERVE[3:]).fly_until(crossing(0)).aim((0.0, 0.3), 0.4)
    s.fly_until(lambda p, v: p[1] > -0.035)
    s.strike(s.v * [1.0, -0.2, 1.0])  # the net stops it
    s.fly(2.0)
    record = run(s)
    assert (record.fault.player, record.fault.kind) == (0, "net")


def test_a_second_stroke_in_the_air_is_a_double_hit():
    s = Script(SERVE[:3], SERVE[3:]).fly_until(crossing(0)).aim((-0.3, 0.9))
    s.fly(0.1).strike(s.v + [0.0, 1.0, 1.0]).fly(2.0)
    record = run(s)
    assert (record.fault.player, record.fault.kind) == (0, "double_hit")


def test_two_bounces_on_the_receivers_half_are_a_double_bounce():
    # A's soft lob lands just past the net: it bounces again before the end of B's half.
    s = a_returns(Script(SERVE[:3], SERVE[3:]), goal=(0.0, 0.3))
    goal = (0.0, 0.3, TABLE.surface_z + MODEL.params.radius)
    s.v = solve_outgoing_velocity(s.p, goal, 1.0, MODEL)
    s.fly(3.0)
    record = run(s)
    assert [e.player for e in record.exchanges] == [0]
    assert (record.fault.player, record.fault.kind) == (1, "double_bounce")


def test_a_ball_that_never_comes_down_after_the_stroke_is_no_landing():
    # A's stroke stops the ball dead, and it stays there (caught on the racket).
    s = Script(SERVE[:3], SERVE[3:]).fly_until(crossing(0))
    held = s.p.copy()
    s.samples += [(s.t + k * DT, held, np.zeros(3)) for k in range(1, round(3.5 / DT))]
    record = run(s, RallyConfig(exchange_timeout=3.0))
    assert (record.fault.player, record.fault.kind) == (0, "no_landing")


def test_a_ball_that_goes_by_is_missed_by_the_receiver():
    record = run(Script(SERVE[:3], SERVE[3:]).fly(3.0))
    assert record.exchanges == ()
    assert (record.fault.player, record.fault.kind) == (0, "missed")
    assert record.fault.incoming_speed is not None  # taken where it crossed A's hitting plane


def test_each_exchange_records_the_ball_its_stroke_sent_in_the_strikers_frame():
    s = a_returns(Script(SERVE[:3], SERVE[3:]))
    sent_a = s.v.copy()
    s.fly_until(crossing(1)).aim((0.3, -0.9))
    sent_b = s.v.copy()
    s.fly_until(crossing(0)).aim((-0.2, 0.8))
    s.fly(3.0)
    record = run(s, RallyConfig(max_exchanges=3))
    # The referee's first sample after the stroke: one step (4 ms) of flight from it.
    for exchange, sent in zip(record.exchanges[:2], (sent_a, sent_b), strict=True):
        out = np.asarray(exchange.outgoing)
        v_side = np.asarray(to_side(exchange.player, *sent))
        np.testing.assert_allclose(out[3:6], v_side, atol=0.05)  # g dt = 0.04 m/s
        assert out[4] > 0.0  # toward the opponent, in the striker's frame
    assert "outgoing" in record.exchanges[0].as_dict()
