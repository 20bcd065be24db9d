"""Record the outcomes of fixed serves and rallies for every player
(tests/data/recorded_outcomes.json).

Run from the repository root to write the file again:

    .venv/bin/python -m tests.data.make_recorded_outcomes

The cases: each player (``analytical``; ``momp`` with the shipped paper set; ``momp`` with the
hard set, as ``tt-drake serve --artefacts hard`` plays it; ``crkr``) on two serves of seed 1 of
the ``default`` and the ``real-train`` distributions (:data:`SERVES`), as ``tt-drake serve
--seed 1`` plays them; and one rally (seed 3, at most 3 exchanges) of analytical against
analytical and of momp against momp, as ``tt-drake rally`` plays them. Every float is kept
exactly (JSON writes a float's shortest repr, which reads back to the same double);
tests/diagrams/test_recorded_outcomes.py compares the same runs with the file bit for bit.
"""

import json
from pathlib import Path

from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import shipped_artefact, use_artefact_set
from tt_drake.seeds import episode_seed

PATH = Path(__file__).with_name("recorded_outcomes.json")

SERVE_SEED = 1
#: Per distribution, the serves (their indices in the run) each player plays: real-train's 73 is
#: a serve the hard set hits twice (a fault), 7 one the teacher returns.
SERVES = {"default": (0, 1), "real-train": (73, 7)}
#: (case label, player, shipped artefact set or None)
SERVE_PLAYERS = (("analytical", "analytical", None), ("momp", "momp", "paper"),
                 ("momp-hard", "momp", "hard"), ("crkr", "crkr", "paper"))
RALLY_SEED = 3
RALLY_EXCHANGES = 3
RALLY_PLAYERS = (("analytical", "analytical"), ("momp", "momp"))


def serve_scenario(player: str, artefact_set: str | None, distribution: str):
    """The scenario ``tt-drake serve --player P [--artefacts S] --distribution D --seed 1``
    plays: the default scenario with the shipped set (the ``crkr`` player keeps its CrKR
    configuration) and the run's seed dealing the pools."""
    scenario = load_scenario("default")
    scenario.launcher.distribution = distribution
    scenario.launcher.run_seed = SERVE_SEED
    if artefact_set is not None:
        use_artefact_set(scenario.learned, artefact_set, configuration_given=player == "crkr")
    return scenario


def rally_case_scenario(players: tuple[str, str]):
    """The scenario ``tt-drake rally --players A B --seed 3 --max-exchanges 3`` plays: the
    analytical hitting configuration, spin-aware, with the shipped primitive library."""
    scenario = load_scenario("default")
    scenario.rally.max_exchanges = RALLY_EXCHANGES
    scenario.launcher.run_seed = RALLY_SEED
    scenario.learned.configuration = "analytical"
    scenario.learned.spin_aware = True
    if "momp" in players:
        scenario.learned.library = str(shipped_artefact("library"))
    return rally_scenario(scenario)


def serve_record(result) -> dict:
    """What a serve episode pins: the launch, the referee's verdict (exact floats) and when the
    episode ended."""
    o = result.outcome
    return {"seed": result.seed, "launch_state": [float(c) for c in result.launch_state],
            "outcome": o.outcome, "hit": o.hit, "returned": o.returned,
            "on_target": o.on_target, "faults": list(o.faults),
            "landing": None if o.landing is None else [float(c) for c in o.landing],
            "hit_time": None if o.hit_time is None else float(o.hit_time),
            "reward": float(o.reward), "duration": float(result.duration)}


def rally_record(result) -> dict:
    """What a rally pins: every exchange (who, when, where it landed, the incoming ball), the
    fault that ended it, whether it was capped and when it ended (exact floats)."""
    fault = result.fault
    return {"seed": result.seed, "launch_state": [float(c) for c in result.launch_state],
            "exchanges": [{"player": e.player, "hit_time": float(e.hit_time),
                           "landing": [float(c) for c in e.landing],
                           "incoming_speed": float(e.incoming_speed),
                           "incoming_spin": [float(c) for c in e.incoming_spin]}
                          for e in result.exchanges],
            "fault": None if fault is None else {"player": fault.player, "kind": fault.kind,
                                                 "t": float(fault.t)},
            "capped": result.capped, "duration": float(result.duration)}


def serve_case_key(label: str, distribution: str) -> str:
    return f"{label}/{distribution}"


def rally_case_key(players: tuple[str, str]) -> str:
    return " vs ".join(players)


def play_serves(label: str, distribution: str) -> list[dict]:
    """The records of the serve case ``label`` on ``distribution`` (one diagram, its serves in
    order, as ``tt-drake serve`` runs them)."""
    _, player, artefact_set = next(c for c in SERVE_PLAYERS if c[0] == label)
    diagram = ServeDiagram(serve_scenario(player, artefact_set, distribution), player)
    return [serve_record(diagram.run(episode_seed(SERVE_SEED, i))) for i in SERVES[distribution]]


def play_rally(players: tuple[str, str]) -> dict:
    """The record of the rally case of ``players`` (rally 0 of the run's seed)."""
    diagram = RallyDiagram(rally_case_scenario(players), players)
    return rally_record(diagram.run(episode_seed(RALLY_SEED, 0)))


def record_all() -> dict:
    """Every case's records, keyed by :func:`serve_case_key` and :func:`rally_case_key`."""
    return {"serves": {serve_case_key(label, d): play_serves(label, d)
                       for label, _, _ in SERVE_PLAYERS for d in SERVES},
            "rallies": {rally_case_key(p): play_rally(p) for p in RALLY_PLAYERS}}


def load_recorded() -> dict:
    with open(PATH, encoding="utf-8") as f:
        return json.load(f)


if __name__ == "__main__":
    PATH.write_text(json.dumps(record_all(), indent=1) + "\n", encoding="utf-8")
    print(f"wrote {PATH}")
