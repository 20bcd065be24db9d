"""What a player's returns look like: pace, spin and placement of the balls it sends.

A return is the ball's state (p, v, omega) just after the racket, in the returner's frame or the
world's: a ball travelling toward -y is first turned a half-turn about the vertical through the
table's centre (the rally's mirror, :func:`tt_drake.rally_rules.to_side`), so every return is
seen from its returner's end. Each is flown with the project's ball model (drag, Magnus, the
table's bounce):

- ``speed_at_net``: the ball's speed where it crosses the net's plane y = 0 (m/s), percentiles
  10, 50 and 90;
- ``topspin_share``: the share of returns whose spin turns the ball's top forward,
  omega . (z x d) > 0 with d the unit horizontal direction of travel (a topspin ball dips; a
  backspin ball floats);
- ``landing_std``: the standard deviations of where the returns first land on the table,
  across (x) and along (y) it (m).

The same function describes the real rally balls of ``tt_drake/data/rallies.json`` (states just
after the opponent's racket) and the robots' returns in ``tt-drake rally``.
"""

from __future__ import annotations

import json
from collections.abc import Iterable

import numpy as np

from tt_drake.ball_model import BallModel
from tt_drake.data import ball_states_path
from tt_drake.racket_impact import topspin
from tt_drake.rally_rules import to_side
from tt_drake.serves import load_ball_states


def from_returners_end(state) -> np.ndarray:
    """A return's (p, v, omega) seen from its returner's end: as it is if it travels toward +y,
    else turned by M = Rz(pi) (position, velocity and spin alike)."""
    s = np.asarray(state, dtype=float).reshape(-1)[:9]
    if s[4] >= 0.0:
        return s
    return np.array([c for k in range(3) for c in to_side(1, *s[3 * k:3 * k + 3])])


def outgoing_figures(states: Iterable, model: BallModel | None = None) -> dict | None:
    """``speed_at_net`` ({p10, p50, p90}, m/s), ``topspin_share`` and ``landing_std`` ([across,
    along], m) of the returns ``states`` (each p, v, omega: 9 floats), with ``n`` (how many),
    ``at_net`` (how many crossed the net's plane) and ``landed`` (how many reached the table).
    Returns None for no returns."""
    model = model or BallModel()
    rows = [from_returners_end(s) for s in states]
    if not rows:
        return None
    speeds, landings = [], []
    for s in rows:
        crossing = model.predict_plane(s, 0.0) if s[1] != 0.0 else None
        if crossing is not None and not crossing.bounces:
            speeds.append(float(np.linalg.norm(crossing.velocity)))
        bounce = model.first_bounce(s)
        if bounce is not None:
            landings.append(bounce.position[:2])
    spins = [topspin(s) for s in rows]
    p = np.percentile(speeds, [10, 50, 90]) if speeds else [np.nan] * 3
    std = np.std(np.asarray(landings), axis=0) if landings else [np.nan, np.nan]
    return {"n": len(rows), "at_net": len(speeds), "landed": len(landings),
            "speed_at_net": {f"p{q}": round(float(x), 3)
                             for q, x in zip((10, 50, 90), p, strict=True)},
            "topspin_share": round(float(np.mean(np.asarray(spins) > 0.0)), 4),
            "landing_std": [round(float(x), 4) for x in std]}


def real_rally_figures() -> dict:
    """:func:`outgoing_figures` of every ball of ``rallies.json`` (states right after a human or
    robot hit in a real rally, in the world frame)."""
    _, states = load_ball_states(ball_states_path("rallies"))
    return outgoing_figures(states)


def main() -> None:
    """``python -m tt_drake.rally_stats``: the real rally balls' figures, as JSON."""
    print(json.dumps(real_rally_figures()))


if __name__ == "__main__":
    main()
