"""Scenarios: everything a simulated episode depends on, as dataclasses loaded from YAML.

In Drake's style (``examples/hardware_sim``): a :class:`Scenario` dataclass whose fields are the
configs of the systems it wires (Drake's own ``MultibodyPlantConfig`` and ``SimulatorConfig``
among them), loaded with ``yaml_load_typed`` so that a misspelt or unknown field is an error.
``models/default.yaml`` is the default scenario; ``load_scenario("default")`` finds it by name.
"""


from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from tt_drake.referee_rules import RefereeConfig
from tt_drake.systems.aerodynamics import AerodynamicsConfig
from tt_drake.systems.ball_launcher import LauncherConfig
from tt_drake.systems.world import WorldConfig


@dataclass
class ControllerConfig:
    """Gains of the arm's InverseDynamicsController (per joint)."""

    kp: list[float] = field(default_factory=lambda: [900.0] * 7)
    ki: list[float] = field(default_factory=lambda: [0.0] * 7)
    kd: list[float] = field(default_factory=lambda: [60.0] * 7)


@dataclass
class LearnedPlayerConfig:
    """Artefacts of the learned (``momp``) player: the primitive library and CrKR model from
    ``tt-drake train library|crkr``, the GPR predictor from ``tt-drake train-predictor`` (empty:
    the physical-model predictor), and where the hitting configuration comes from: ``crkr`` or
    ``analytical`` (the teacher's IK on the predicted stimulus). With ``early_prediction`` the
    physical model predicts from every estimate of the approaching ball until the predictor's
    final prediction, so the momp player's preparation stage starts when the ball is detected
    (paper section III-C); without, it waits for the final prediction, as the ``crkr`` player
    always does."""

    library: str = ""
    crkr: str = ""
    predictor: str = ""
    configuration: str = "crkr"
    early_prediction: bool = True


@dataclass
class Scenario:
    name: str = "default"
    world: WorldConfig = field(default_factory=WorldConfig)
    launcher: LauncherConfig = field(default_factory=LauncherConfig)
    aerodynamics: AerodynamicsConfig = field(default_factory=AerodynamicsConfig)
    referee: RefereeConfig = field(default_factory=RefereeConfig)
    referee_rate: float = 250.0  # Hz
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    # An episode lasts until the predicted crossing of the hitting plane plus this long (s).
    after_crossing: float = 1.2
    learned: LearnedPlayerConfig = field(default_factory=LearnedPlayerConfig)
    # What the players see: ``camera`` (60 Hz, noisy, through the EKF) or ``oracle`` (the
    # simulator's true ball state at 60 Hz, no noise; docs/serves.md).
    perception: str = "camera"


class ScenarioError(ValueError):
    """A scenario file is missing, malformed or has unknown or invalid fields."""


def scenario_path(name_or_path: str) -> Path:
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml") or path.exists():
        return path
    return Path(str(resources.files("tt_drake.models").joinpath(f"{name_or_path}.yaml")))


def load_scenario(name_or_path: str = "default") -> Scenario:
    """Load a scenario by name (``models/<name>.yaml``) or path; raise ScenarioError on any
    problem, with one line that names it."""
    path = scenario_path(name_or_path)
    if not path.is_file():
        raise ScenarioError(f"scenario file not found: {path}")
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path), defaults=Scenario())
    except Exception as err:  # yaml and schema errors come as several exception types
        message = " ".join(str(err).split())
        raise ScenarioError(f"invalid scenario {path}: {message}") from None
    validate(scenario, path)
    return scenario


def validate(scenario: Scenario, origin: object = "scenario") -> None:
    """Checks the YAML schema cannot express."""
    from tt_drake.serves import DISTRIBUTIONS
    from tt_drake.systems.ball_oracle import PERCEPTIONS

    problems = []
    if scenario.launcher.distribution not in DISTRIBUTIONS:
        problems.append(f"launcher.distribution {scenario.launcher.distribution!r} is not one of "
                        f"{', '.join(DISTRIBUTIONS)}")
    if not scenario.launcher.spin_max >= 0.0:
        problems.append(f"launcher.spin_max must be >= 0 rad/s, got {scenario.launcher.spin_max}")
    if scenario.perception not in PERCEPTIONS:
        problems.append(f"perception {scenario.perception!r} is not one of "
                        f"{', '.join(PERCEPTIONS)}")
    if scenario.world.simulator.max_step_size <= 0:
        problems.append("world.simulator.max_step_size must be > 0")
    if scenario.referee_rate <= 0:
        problems.append("referee_rate must be > 0")
    if scenario.after_crossing <= 0:
        problems.append("after_crossing must be > 0")
    for gains in ("kp", "ki", "kd"):
        if len(getattr(scenario.controller, gains)) != 7:
            problems.append(f"controller.{gains} needs 7 values")
    if problems:
        raise ScenarioError(f"invalid scenario {origin}: " + "; ".join(problems))


def dump_scenario(scenario: Scenario) -> str:
    return yaml_dump_typed(scenario)
