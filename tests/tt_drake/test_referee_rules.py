"""Referee: scripted ball trajectories (no robot) for every outcome class.

The scripts fly the ball with the numpy model (table bounces included), add a floor and a net for
the script's sake, and replace the ball's velocity at a chosen time to play the racket's hit. The
referee sees only 250 Hz samples of the ball state, as in the Drake diagram.
"""

import math

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import NET, TABLE, TARGET
from tt_drake.rally_rules import Exchange, RallyFault, receiver_after, table_fault
from tt_drake.referee_rules import (
    ROBOT_TABLE,
    ContactDetector,
    ContactEvent,
    RefereeConfig,
    judge,
    table_toucher,
)

MODEL = BallModel()
R = MODEL.params.radius


def script(launch, hit_at=None, hit_velocity=None, duration=2.5, rate=250.0, h=5e-4):
    """Sampled states of a scripted flight; returns the referee's outcome."""
    pos, vel, w = tuple(launch[0:3]), tuple(launch[3:6]), (0.0, 0.0, 0.0)
    detector = ContactDetector(RefereeConfig(), MODEL)
    events = []
    t, next_sample, hit_done = 0.0, 0.0, False
    while t < duration:
        if t >= next_sample - 1e-12:
            e = detector.update(t, pos, vel)
            if e is not None:
                events.append(e)
            next_sample += 1.0 / rate
        if hit_at is not None and not hit_done and t >= hit_at:
            vel, hit_done = tuple(hit_velocity), True
        new_p, new_v = MODEL.flight_step(pos, vel, w, h)
        if new_p[2] < TABLE.surface_z + R <= pos[2] and MODEL.over_table(new_p[0], new_p[1]):
            new_v, w = MODEL.bounce(new_v, w)
            new_p = (new_p[0], new_p[1], TABLE.surface_z + R)
        if new_p[2] < R and new_v[2] < 0:  # floor: a dead bounce
            new_v = (0.5 * new_v[0], 0.5 * new_v[1], -0.5 * new_v[2])
        net_top = TABLE.surface_z + NET.height
        if pos[1] * new_p[1] <= 0 and new_p[2] < net_top + R and new_p[2] > TABLE.surface_z:
            new_v = (0.2 * new_v[0], -0.1 * new_v[1], 0.2 * new_v[2])  # caught by the net
            new_p = (new_p[0], math.copysign(R + 0.006, pos[1]), new_p[2])
        pos, vel, t = new_p, new_v, t + h
    return events


SERVE = np.array([0.1, 1.57, 0.91, 0.25, -5.2, 3.0])


def crossing_time():
    return MODEL.predict_plane(np.r_[SERVE, 0, 0, 0], -1.82).t


def return_velocity(target_y, vy=4.5):
    """Bisection on v_z for a return from the hitting point that lands at (TARGET.x, target_y)."""
    crossing = MODEL.predict_plane(np.r_[SERVE, 0, 0, 0], -1.82)
    p = crossing.position
    lo, hi = -2.0, 6.0
    for _ in range(60):
        vz = 0.5 * (lo + hi)
        vx = (TARGET.x - p[0]) / ((target_y - p[1]) / vy)
        c = MODEL.predict_plane(np.r_[p, vx, vy, vz, 0, 0, 0], target_y)
        if c is None or c.bounces or c.position[2] < TABLE.surface_z + R:
            lo = vz
        else:
            hi = vz
    return np.array([vx, vy, hi])


def test_missed_serve():
    outcome = judge(script(SERVE))
    assert outcome.outcome == "missed" and not outcome.hit and outcome.reward == 0.0
    assert outcome.faults == []


def test_legal_return_on_target():
    events = script(SERVE, crossing_time(), return_velocity(TARGET.y))
    outcome = judge(events)
    assert [e.kind for e in events[:3]] == ["table", "racket", "table"]
    assert outcome.outcome == "returned" and outcome.hit and outcome.on_target
    assert outcome.landing[1] == pytest.approx(TARGET.y, abs=0.1)
    assert outcome.target_distance < 0.1 and outcome.reward > 0.95


def test_legal_return_off_target_earns_less():
    outcome = judge(script(SERVE, crossing_time(), return_velocity(1.2)))
    assert outcome.outcome == "returned" and not outcome.on_target
    d = outcome.target_distance
    assert outcome.reward == pytest.approx(0.3 + 0.7 * math.exp(-d * d / (2 * 0.3**2)))
    assert 0.3 < outcome.reward < 0.95


def test_a_legal_return_far_off_target_is_worth_less_than_the_pruning_level():
    """Responsibility learning eventually prunes a primitive whose mean reward stays below
    ResponsibilityParams().prune_below_reward: a return that always lands far off must be."""
    from tt_drake.responsibility import ResponsibilityParams

    far = judge(script(SERVE, crossing_time(), return_velocity(1.3)))
    near = judge(script(SERVE, crossing_time(), return_velocity(TARGET.y)))
    assert far.returned and near.returned and far.target_distance > 0.6
    assert far.reward < ResponsibilityParams().prune_below_reward < near.reward
    # the floor changes rewards only: a return is legal whatever it is worth
    floored = judge(script(SERVE, crossing_time(), return_velocity(1.3)),
                    config=RefereeConfig(return_floor=0.9))
    assert floored.outcome == far.outcome and floored.landing == far.landing
    assert floored.reward > 0.9


def test_net_fault():
    outcome = judge(script(SERVE, crossing_time(), np.array([0.0, 10.0, 0.0])))
    assert outcome.outcome == "fault" and outcome.faults == ["net"]
    assert outcome.reward == pytest.approx(0.2)


def test_out_long():
    outcome = judge(script(SERVE, crossing_time(), np.array([0.0, 9.0, 3.0])))
    assert outcome.outcome == "fault" and outcome.faults == ["out"]


def test_own_half():
    outcome = judge(script(SERVE, crossing_time(), np.array([0.0, 4.0, -1.0])))
    assert outcome.faults == ["own_half"] and outcome.landing[1] < 0


def test_double_bounce_before_the_hit_is_recorded():
    slow = np.array([0.1, -0.5, 0.95, 0.0, -0.8, 0.0])  # short bounces on the robot's half
    outcome = judge(script(slow, duration=3.0))
    assert outcome.outcome == "missed" and "double_bounce" in outcome.faults


def test_robot_touching_the_table_caps_the_reward():
    events = script(SERVE, crossing_time(), return_velocity(TARGET.y))
    outcome = judge(events, robot_touched_table=True)
    assert outcome.returned and "robot_table" in outcome.faults and outcome.reward <= 0.1


def test_the_return_is_decided_by_the_first_table_net_or_floor_contact_after_the_hit():
    """An early end of the episode (the referee's stop_when_decided) must leave judge's verdict
    unchanged: a racket contact straddling two samples (two racket events 4 ms apart) does not
    end it, the landing after the hit does, and so do the net and the floor."""
    from tt_drake.referee_rules import ContactEvent, decides_return

    bounce = ContactEvent(0.30, "table", np.array([0.1, -0.8, 0.78]))
    hit = ContactEvent(0.70, "racket", np.array([0.2, -1.82, 1.0]))
    again = ContactEvent(0.704, "racket", np.array([0.2, -1.81, 1.0]))
    landing = ContactEvent(1.20, "table", np.array([0.0, 0.7, 0.78]))
    assert not decides_return([bounce], hit)
    assert not decides_return([bounce, hit], again)
    assert not decides_return([], bounce)
    assert decides_return([bounce, hit, again], landing)
    assert decides_return([bounce, hit], ContactEvent(1.0, "floor", np.zeros(3)))
    # the net decides nothing: a ball touching it may still drop onto the opponent's court
    assert not decides_return([bounce, hit], ContactEvent(1.0, "net", np.zeros(3)))
    full = judge([bounce, hit, again, landing, ContactEvent(1.6, "floor", np.zeros(3))])
    cut = judge([bounce, hit, again, landing])
    assert full.as_dict() == cut.as_dict() and cut.returned


# -- the rules on hand-made contact sequences (ITTF Laws 2.7.1, 2.10.1.3) -----------------------

def contacts(*items):
    """ContactEvents from (t, kind, y) triples (x = 0.1, z at the table or the floor)."""
    from tt_drake.referee_rules import ContactEvent

    z = {"table": TABLE.surface_z + R, "floor": R}
    return [ContactEvent(t, kind, (0.1, y, z.get(kind, TABLE.surface_z + 0.1)))
            for t, kind, y in items]


def test_a_ball_hit_after_two_bounces_on_the_robots_half_is_a_lost_point():
    """Two bounces on the receiver's half end the point: the stroke after them is no return,
    however well it lands, and earns a failed stroke's reward."""
    legal = contacts((0.3, "table", -0.4), (0.7, "racket", -1.8), (1.2, "table", 0.9))
    late = contacts((0.3, "table", -0.4), (0.55, "table", -1.2), (0.7, "racket", -1.8),
                    (1.2, "table", 0.9))
    assert judge(legal).returned
    outcome = judge(late)
    assert outcome.outcome == "fault" and not outcome.returned and not outcome.on_target
    assert outcome.faults == ["double_bounce"] and outcome.reward == pytest.approx(0.2)
    # a serve's bounce on the server's half (y > 0) is not the receiver's
    real = contacts((0.1, "table", 0.5), (0.3, "table", -0.4), (0.7, "racket", -1.8),
                    (1.2, "table", 0.9))
    assert judge(real).returned


@pytest.mark.parametrize("after_net, outcome, faults", [
    (("table", 0.4), "returned", []),  # Law 2.7.1: over the net assembly, touching it
    (("table", -0.3), "fault", ["net"]),  # it fell back on the striker's half
    (("floor", -0.2), "fault", ["net"]),  # it fell back off the table on the striker's side
    (("floor", 2.5), "fault", ["out"]),  # over, but long
])
def test_a_return_touching_the_net_is_judged_by_where_it_lands(after_net, outcome, faults):
    events = contacts((0.3, "table", -0.4), (0.7, "racket", -1.8), (1.0, "net", 0.0),
                      (1.1, after_net[0], after_net[1]))
    verdict = judge(events)
    assert verdict.outcome == outcome and verdict.faults == faults and verdict.net_touch
    assert verdict.returned == (outcome == "returned")
    clean = judge(contacts((0.3, "table", -0.4), (0.7, "racket", -1.8), (1.1, "table", 0.4)))
    assert clean.returned and not clean.net_touch
    # the same landing earns the same reward with or without the touch
    if verdict.returned:
        assert verdict.reward == pytest.approx(clean.reward)


def test_a_return_caught_by_the_net_is_a_net_fault():
    verdict = judge(contacts((0.3, "table", -0.4), (0.7, "racket", -1.8), (1.0, "net", 0.0)))
    assert verdict.outcome == "fault" and verdict.faults == ["net"]


def test_the_rally_reads_the_same_rules():
    """The rally's decide follows the serve's judge on every sequence above: a net touch that
    lands over is an exchange; one with nothing after it waits (until the timeout); two bounces
    before the hit end the exchange whatever follows."""
    from tt_drake.rally_rules import decide

    over = contacts((0.3, "table", -0.4), (0.7, "racket", -1.8), (1.0, "net", 0.0),
                    (1.1, "table", 0.4))
    assert decide(over, 1.2, 0.3, 3.0) == ("returned", (0.1, 0.4))
    caught = over[:3]
    assert decide(caught, 1.2, 0.3, 3.0) is None
    assert decide(caught, 3.5, 0.3, 3.0) == ("fault", "net")
    late = contacts((0.3, "table", -0.4), (0.55, "table", -1.2), (0.7, "racket", -1.8),
                    (1.2, "table", 0.9))
    assert decide(late, 1.3, 0.3, 3.0) == ("fault", "double_bounce")
    assert decide(late[:2], 0.6, 0.3, 3.0) == ("fault", "double_bounce")
    for events in (over, late):
        verdict = judge(events)
        assert decide(events, 1.3, 0.3, 3.0)[0] == ("returned" if verdict.returned else "fault")


def test_no_verdict_returns_a_ball_that_bounced_twice_before_the_hit():
    """Over random contact sequences (every kind, anywhere on either half), judge calls none
    ``returned`` whose ball bounced twice on the robot's half before the racket's first touch,
    and the rally's decide agrees with judge on every sequence that ends decided."""
    from tt_drake.rally_rules import decide
    from tt_drake.referee_rules import receiver_bounces

    rng = np.random.default_rng(7)
    kinds = ["table", "table", "table", "racket", "net", "floor"]
    seen_late_hits = 0
    for _ in range(3000):
        n = int(rng.integers(1, 7))
        items = [(0.2 * (k + 1), str(rng.choice(kinds)), float(rng.uniform(-1.3, 1.3)))
                 for k in range(n)]
        events = contacts(*items)
        verdict = judge(events)
        late = receiver_bounces(events) >= 2
        if late and verdict.hit:
            seen_late_hits += 1
            assert not verdict.returned and "double_bounce" in verdict.faults
        if verdict.returned:
            assert receiver_bounces(events) <= 1
        rally = decide(events, 10.0, 0.0, 3.0)
        if rally is not None and verdict.hit:
            assert (rally[0] == "returned") == verdict.returned
    assert seen_late_hits > 50


# Hand-made contact pairs (body A, body B, geometry A, geometry B), as the referees read the
# plant's contact results: bodies and geometries by made-up ids.
TABLE_BODY, BALL, FLOOR_BODY = 1, 2, 3
ARM_A, RACKET_A, ARM_B, RACKET_B = 8, 10, 18, 20
ROBOTS = ({6, 7, ARM_A, 9, RACKET_A}, {16, 17, ARM_B, 19, RACKET_B})
TABLE_TOP = {"table_top"}
BOUNCE = (BALL, TABLE_BODY, "ball", "table_top")


def test_a_robot_body_on_the_table_top_is_the_touch_and_nothing_else_is():
    """Which contact counts (both referees): a robot body against a table-top geometry, in
    either order of the pair, the arm's links as well as the racket; the ball on the table, a
    robot on the net or the floor, and a world without a table top's geometries do not."""
    assert table_toucher([], ROBOTS, TABLE_TOP) is None
    assert table_toucher([BOUNCE], ROBOTS, TABLE_TOP) is None
    assert table_toucher([(RACKET_A, TABLE_BODY, "blade", "net"),
                          (FLOOR_BODY, ARM_B, "floor", "forearm")], ROBOTS, TABLE_TOP) is None
    assert table_toucher([(RACKET_A, BALL, "blade", "ball")], ROBOTS, TABLE_TOP) is None
    on_a = (RACKET_A, TABLE_BODY, "blade", "table_top")
    on_b = (TABLE_BODY, ARM_B, "table_top", "forearm")
    assert table_toucher([BOUNCE, on_a], ROBOTS, TABLE_TOP) == 0
    assert table_toucher([on_b], ROBOTS, TABLE_TOP) == 1
    assert table_toucher([on_b, on_a], ROBOTS, TABLE_TOP) == 1  # the first pair's robot
    assert table_toucher([on_a], ROBOTS, set()) is None
    # The serve's referee: one robot.
    assert table_toucher([BOUNCE, on_a], ROBOTS[:1], TABLE_TOP) == 0
    assert table_toucher([on_b], ROBOTS[:1], TABLE_TOP) is None


def test_a_touch_over_a_rallys_samples_ends_it_on_the_touchers_point():
    """The contacts of successive referee samples: the ball bounces, A's racket touches the table
    while B is receiving. The first sample with the touch gives A's ``robot_table`` fault (A
    loses the point, though B had the ball), without the ball B had to return; a receiver's own
    touch keeps the ball it had to return, as its other faults do."""
    samples = [[], [BOUNCE], [BOUNCE], [], [(TABLE_BODY, RACKET_A, "table_top", "blade")], []]
    exchanges = [Exchange(0, 0.7, (-0.3, 0.9), 5.0, (0.0, 80.0, 0.0))]
    receiver = receiver_after(exchanges)
    assert receiver == 1
    incoming = (6.0, (1.0, 2.0, 3.0), True)  # B's ball, seen where it crossed B's plane
    fault = None
    for k, pairs in enumerate(samples):
        toucher = table_toucher(pairs, ROBOTS, TABLE_TOP)
        if toucher is not None:
            fault = table_fault(toucher, receiver, 0.004 * k, incoming)
            break
    assert fault == RallyFault(0, ROBOT_TABLE, 0.016, None, None)
    assert table_fault(1, 1, 0.016, incoming) == RallyFault(1, ROBOT_TABLE, 0.016, 6.0,
                                                            (1.0, 2.0, 3.0))
    assert table_fault(0, 0, 0.2, None) == RallyFault(0, ROBOT_TABLE, 0.2, None, None)
    assert receiver_after([]) == 0
    assert receiver_after([*exchanges, Exchange(1, 1.7, (-0.3, 0.9), 5.0, (0.0, 0.0, 0.0))]) == 0



def test_a_return_striking_the_tables_end_face_is_a_table_side_fault():
    """A ball struck from below the table's height that meets the striker's own end face: the
    samples around the contact (a rally's, at 250 Hz: rising at 7.5 m/s, then bounced back)
    are a contact with the table's side, not the robot's (the racket 0.2 m away), and after
    the hit it is the ``table_side`` fault; a bounce on the top by the edge stays a table
    contact, and the same jump far from the table and the robot is no contact."""
    detector = ContactDetector(RefereeConfig(), MODEL)
    edge = TABLE.robot_edge_y
    racket = (-0.22, edge - 0.23, 0.70)
    before = (0.596, (-0.187, edge - 0.033, 0.740), (1.39, 7.47, 2.26))
    after = (0.600, (-0.183, edge - 0.030, 0.748), (0.83, -5.65, 1.67))
    event = detector.detect(ContactDetector.sample(*before, racket=racket),
                            ContactDetector.sample(*after, racket=racket))
    assert event is not None and event.kind == "table_side"
    hit = judge([ContactEvent(0.5, "racket", (-0.23, edge - 0.31, 0.65)), event])
    assert hit.outcome == "fault" and hit.faults == ["table_side"] and not hit.returned
    # on the top, 1 cm inside the end line, falling: a bounce on the table
    top = detector.detect(
        ContactDetector.sample(0.0, (0.1, edge + 0.01, TABLE.surface_z + R + 0.005),
                               (0.0, -4.0, -2.0), racket=racket),
        ContactDetector.sample(0.004, (0.1, edge + 0.01 - 0.016, TABLE.surface_z + R + 0.004),
                               (0.0, -4.0, 1.8), racket=racket))
    assert top is not None and top.kind == "table"
    far = detector.detect(
        ContactDetector.sample(0.0, (1.5, 0.0, 1.2), (0.0, 3.0, 0.0), racket=racket),
        ContactDetector.sample(0.004, (1.5, 0.012, 1.2), (0.0, -3.0, 0.0), racket=racket))
    assert far is None
