"""Scenarios: everything a simulated episode depends on, as dataclasses loaded from YAML.

In Drake's style (``examples/hardware_sim``): a :class:`Scenario` dataclass whose fields are the
configs of the systems it wires (Drake's own ``MultibodyPlantConfig`` and ``SimulatorConfig``
among them), loaded with ``yaml_load_typed`` so that a misspelt or unknown field is an error.
``models/default.yaml`` is the default scenario; ``load_scenario("default")`` finds it by name.
"""


import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from tt_drake.camera_model import CameraConfig
from tt_drake.referee_rules import RefereeConfig
from tt_drake.systems.aerodynamics import AerodynamicsConfig
from tt_drake.systems.ball_launcher import LauncherConfig
from tt_drake.systems.world import WorldConfig


def _zeros7() -> list[float]:
    return [0.0] * 7


@dataclass
class ControllerConfig:
    """The arm's InverseDynamicsController and how its model differs from the simulated arm.

    Gains per joint (acceleration units, ``tt_drake.systems.wam``). Model mismatch (defaults:
    none, the controller's model is the simulated arm): the controller's link masses are
    ``mass_scale`` times the simulated ones and its rotational inertias about the links' centres
    of mass ``inertia_scale`` times; the simulated arm has joint friction the controller does not
    know, ``tau_j = -joint_coulomb[j] tanh(v_j / coulomb_velocity) - joint_viscous[j] v_j``
    (N m, N m s/rad, rad/s), and Gaussian motor torque noise of standard deviation
    ``torque_noise[j]`` (N m), drawn once per 500 Hz servo tick from the episode's seed."""

    kp: list[float] = field(default_factory=lambda: [900.0] * 7)
    ki: list[float] = field(default_factory=lambda: [0.0] * 7)
    kd: list[float] = field(default_factory=lambda: [60.0] * 7)
    mass_scale: float = 1.0
    inertia_scale: float = 1.0
    joint_viscous: list[float] = field(default_factory=_zeros7)
    joint_coulomb: list[float] = field(default_factory=_zeros7)
    coulomb_velocity: float = 0.1
    torque_noise: list[float] = field(default_factory=_zeros7)

    def problems(self, prefix: str = "controller.") -> list[str]:
        """What is wrong with the values (one phrase per field, named with ``prefix``): seven
        finite values per joint list, gains and friction and noise >= 0, kp and kd > 0, scales in
        [0.1, 10], coulomb_velocity > 0."""
        out = []
        for name in ("kp", "ki", "kd", "joint_viscous", "joint_coulomb", "torque_noise"):
            values = getattr(self, name)
            if len(values) != 7:
                out.append(f"{prefix}{name} needs 7 values, got {len(values)}")
            elif not all(math.isfinite(v) for v in values):
                out.append(f"{prefix}{name} must be finite, got {list(values)}")
            elif any(v < 0.0 for v in values) or (name in ("kp", "kd")
                                                  and not all(v > 0.0 for v in values)):
                out.append(f"{prefix}{name} must be {'> 0' if name in ('kp', 'kd') else '>= 0'}"
                           f", got {list(values)}")
        for name in ("mass_scale", "inertia_scale"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.1 <= value <= 10.0):
                out.append(f"{prefix}{name} must be in [0.1, 10], got {value}")
        if not (math.isfinite(self.coulomb_velocity) and self.coulomb_velocity > 0.0):
            out.append(f"{prefix}coulomb_velocity must be finite and > 0, got "
                       f"{self.coulomb_velocity}")
        return out


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
    camera: CameraConfig = field(default_factory=CameraConfig)
    # An episode lasts until the predicted crossing of the hitting plane plus this long (s).
    after_crossing: float = 1.2
    learned: LearnedPlayerConfig = field(default_factory=LearnedPlayerConfig)


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

    problems = []
    if scenario.launcher.distribution not in DISTRIBUTIONS:
        problems.append(f"launcher.distribution {scenario.launcher.distribution!r} is not one of "
                        f"{', '.join(DISTRIBUTIONS)}")
    if scenario.world.simulator.max_step_size <= 0:
        problems.append("world.simulator.max_step_size must be > 0")
    if scenario.referee_rate <= 0:
        problems.append("referee_rate must be > 0")
    if scenario.after_crossing <= 0:
        problems.append("after_crossing must be > 0")
    problems += scenario.controller.problems()
    problems += scenario.camera.problems()
    problems += scenario.launcher.problems()
    if problems:
        raise ScenarioError(f"invalid scenario {origin}: " + "; ".join(problems))


def dump_scenario(scenario: Scenario) -> str:
    return yaml_dump_typed(scenario)
