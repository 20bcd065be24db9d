"""Scenarios: everything a simulated episode depends on, as dataclasses loaded from YAML.

In Drake's style (``examples/hardware_sim``): a :class:`Scenario` dataclass whose fields are the
configs of the systems it wires (Drake's own ``MultibodyPlantConfig`` and ``SimulatorConfig``
among them), loaded with ``yaml_load_typed`` so that a misspelt or unknown field is an error.
``models/default.yaml`` is the default scenario; ``load_scenario("default")`` finds it by name.
"""


import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from pydrake.common.yaml import yaml_dump, yaml_dump_typed, yaml_load_data, yaml_load_typed
from pydrake.systems.analysis import GetIntegrationSchemes

from tt_drake.camera_model import CameraConfig
from tt_drake.constants import MAX_EXCHANGES
from tt_drake.drives import SUPPLY_FRACTION
from tt_drake.errors import BadInputError
from tt_drake.rally_aim import AIMS
from tt_drake.rally_rules import RallyConfig
from tt_drake.referee_rules import RefereeConfig
from tt_drake.serves import DISTRIBUTIONS
from tt_drake.stages import StageTimes
from tt_drake.systems.aerodynamics import AerodynamicsConfig
from tt_drake.systems.ball_launcher import LauncherConfig
from tt_drake.systems.ball_oracle import PERCEPTIONS
from tt_drake.systems.hitting_ik import JOINT_MARGIN, SOLVERS
from tt_drake.systems.world import ModelFileError, WorldConfig, is_explicit_path, model_path
from tt_drake.wam_params import (
    DESIGN_VOLTAGE,
    EFFORT_LIMIT,
    JOINT_LOWER,
    JOINT_UPPER,
    SUPPLY_VOLTAGE_RANGE,
)


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
    ``torque_noise[j]`` (N m), drawn once per 500 Hz servo tick from the episode's seed.

    ``drive_voltage`` (V): the arm's DC drives at this supply voltage limit each joint's torque
    by its speed (back EMF: none left at the no-load speed; :mod:`tt_drake.drives`), in the
    simulation and in the players' effort checks; 0: ideal drives, the effort limits only.
    The default is Barrett's design voltage, 48 V (the WAM's supply takes 24-90 V).

    ``drive_aware``: correct the controller's torque, at every servo tick, for joints whose
    drives clamp it (:mod:`tt_drake.systems.drive_correction`): the other joints then get the
    torque of their commanded accelerations given what the clamped joints can do, instead of
    the coupling of accelerations the clamped joints do not make. Off by default; it needs the
    controller's model to be the arm's (``mass_scale`` and ``inertia_scale`` 1)."""

    kp: list[float] = field(default_factory=lambda: [900.0] * 7)
    ki: list[float] = field(default_factory=lambda: [0.0] * 7)
    kd: list[float] = field(default_factory=lambda: [60.0] * 7)
    mass_scale: float = 1.0
    inertia_scale: float = 1.0
    joint_viscous: list[float] = field(default_factory=_zeros7)
    joint_coulomb: list[float] = field(default_factory=_zeros7)
    coulomb_velocity: float = 0.1
    torque_noise: list[float] = field(default_factory=_zeros7)
    drive_voltage: float = DESIGN_VOLTAGE
    drive_aware: bool = False

    def problems(self) -> list[str]:
        """What is wrong with the values: the ``controller.*`` rules of :data:`FIELD_RULES`
        (seven finite values per joint list, gains >= 0, kp and kd > 0, friction and noise in
        [0, the joint's effort limit], scales in [0.1, 10], coulomb_velocity in [0.01, 10],
        drive_voltage 0 or in the supply's 24-90 V), and ``drive_aware`` with a model
        mismatch."""
        return rule_problems(self, "controller") + self.combination_problems()

    def combination_problems(self) -> list[str]:
        """What is wrong with the values together: ``drive_aware`` with a model mismatch."""
        if self.drive_aware and (self.mass_scale != 1.0 or self.inertia_scale != 1.0):
            return ["controller.drive_aware needs the controller's model to be the arm's "
                    "(mass_scale and inertia_scale 1)"]
        return []


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
    # The hitting DMP's moving goal (docs/learned_player.md): the hitting stage follows each new
    # prediction until ``MoMPConfig.goal_cutoff`` before the hit instead of committing at its start.
    # Off in the paper profile; the hard artefacts turn it on (``tt-drake serve --artefacts hard``).
    moving_goal: bool = False
    # The ``analytical`` configuration's racket for the predicted spin at the hit (the teacher's
    # aim and racket law with ``spin_hit``: systems/hitting_configuration.py). Always on with the
    # moving goal; this turns it on without (a rally's learned players, docs/rally.md).
    spin_aware: bool = False
    # With the moving goal: a move of the goal, or a re-plan before the hitting stage, that the
    # limits refuse is made as the teacher's quintic correction (``MoMPConfig.
    # correction_fallback``; docs/learned_player.md). On for the stock robot; ``ideal_robot``
    # turns it off.
    correction_fallback: bool = True
    # With ``correction_fallback``: when that correction is refused too, the teacher's other
    # strokes for the prediction are tried the same way (``MoMPConfig.stroke_fallbacks``;
    # docs/learned_player.md). On for the stock robot; ``ideal_robot`` turns it off.
    stroke_fallbacks: bool = True
    # With the moving goal: the physical model's refreshed predictions start at the final
    # prediction rather than after the robot-side bounce (``HittingPointPredictor.
    # refresh_ahead``), so the goal follows the filter's spin as it converges. On for the stock
    # robot; ``ideal_robot`` turns it off.
    refresh_before_bounce: bool = True
    # With drives (``controller.drive_voltage``): the share of the supply at each joint speed,
    # and of each joint's no-load speed, the learned player's plans may ask for
    # (``MoMPConfig.supply_fraction``); the teacher's 1.5 (docs/learned_player.md, "On the stock
    # robot: the drives' supply"). No effect on ideal drives.
    supply_fraction: float = SUPPLY_FRACTION


@dataclass
class TeacherConfig:
    """The analytical player's planner settings a scenario may change
    (:class:`tt_drake.systems.analytical_player.PlannerConfig`; docs/analytical_player.md). The
    defaults are the stock robot's teacher, each chosen on its validation serves; the shipped
    ``ideal_robot`` scenario sets every one back to the teacher its figures were made with.

    ``correction_fallbacks``: a correction of the committed stroke that the effort check refuses
    tries the planner's fallbacks in turn (less of the spin compensated, the ball met off the
    blade's centre); off, the committed stroke is kept ("Corrections"). ``plan_fallbacks``: a
    first plan the joint or effort limits refuse tries them in the same order; off, only a
    stroke the arm cannot reach does ("Fallbacks"). ``min_hitting`` (s): the hitting stage is
    shortened, to no less than this, where a joint's swing-back is clipped at its limit, so
    that no joint moves back past it (:func:`tt_drake.stages.hitting_duration`); 0: it always
    lasts 0.4 s ("Stages"). ``torque_fraction``: the share of the effort limits a first plan may
    ask for; ``correction_torque_fraction``: the same for a correction of the committed stroke;
    above 0.9 a plan is followed with the arm's lag where it asks for more than the drives give
    after tracking errors ("Effort"); each at most 2. ``awaiting_base`` (rad): the base joint's
    angle in the teacher's awaiting posture, the rest of which is ``wam_params.AWAITING``'s; the
    episode starts the arm there and every stroke returns there ("The awaiting posture").
    ``posture_fallback``: a correction refused in every stroke (and fallback) is tried again
    with the arm nearest the committed stroke's posture in units of the joints' speed limits,
    not the comfort posture ("Corrections"). ``direct_lead`` (s): a stroke with no time for a
    swing-back waits at rest no later than this long before the hit; 0: until its hitting
    stage's start ("Stages"). ``ik_solver``: the solver of the arm's position problem,
    ``snopt`` (Drake's SNOPT) or ``sqp`` (the compiled SQP, about four times faster; the same
    program, each answer to its solver's tolerance, so strokes differ by that:
    docs/hitting_ik.md, "Solvers")."""

    correction_fallbacks: bool = True
    plan_fallbacks: bool = True
    min_hitting: float = 0.1
    torque_fraction: float = 1.2
    correction_torque_fraction: float = 1.2
    awaiting_base: float = -0.55
    posture_fallback: bool = True
    direct_lead: float = 0.5
    ik_solver: str = "snopt"


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
    # What the players see: ``camera`` (60 Hz, noisy, through the EKF) or ``oracle`` (the
    # simulator's true ball state at 60 Hz, no noise; docs/serves.md).
    perception: str = "camera"
    # ``tt-drake rally`` (docs/rally.md): the players' aim, the cap on exchanges.
    rally: RallyConfig = field(default_factory=RallyConfig)
    teacher: TeacherConfig = field(default_factory=TeacherConfig)


class ScenarioError(ValueError, BadInputError):
    """A scenario file is missing, malformed or has unknown or invalid fields."""


def scenario_path(name_or_path: str) -> Path:
    """A scenario file: a ``.yaml`` (``.yml``) file or a path with a folder part
    (:func:`is_explicit_path`) as given; any other name is ``models/<name>.yaml`` of the package
    (a file of that name in the working folder is not looked at)."""
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml") or is_explicit_path(name_or_path):
        return path
    return Path(str(resources.files("tt_drake.models").joinpath(f"{name_or_path}.yaml")))


def resolve_model_paths(scenario: Scenario) -> None:
    """Replace each model file given as a path by its absolute path, so that the scenario a run
    records (its JSON) names the file that was played, wherever the run is replayed from; bare
    names stay, they name the package's files."""
    models = scenario.world.models
    for kind in ("table", "ball") + (("robot",) if scenario.world.with_robot else ()):
        name = getattr(models, kind)
        if name and is_explicit_path(name):
            setattr(models, kind, str(model_path(name)))


def sets_field(name_or_path: str, dotted: str) -> bool:
    """Whether the scenario file itself, or a file it is read on top of with ``base`` (not the
    default scenario under them), names the field ``dotted`` (e.g. ``learned.configuration``): a
    command whose own default differs from the dataclass's applies it only to a scenario that
    leaves the field alone. The file is assumed loadable (:func:`load_scenario` first)."""
    chain = _scenario_chain(scenario_path(name_or_path))
    for _, data in chain[:-1] if len(chain) > 1 else chain:
        found: Any = data
        for key in dotted.split("."):
            if not isinstance(found, dict) or key not in found:
                break
            found = found[key]
        else:
            return True
    return False


#: The key of a scenario file naming the scenario it is read on top of (a name or a path, as
#: ``--scenario`` takes it; a relative path is taken from the file's folder). Without it a file
#: is read on top of the default scenario.
BASE_KEY = "base"


def load_scenario(name_or_path: str = "default") -> Scenario:
    """Load a scenario by name (``models/<name>.yaml``) or path; raise ScenarioError on any
    problem, with one line that names it. Any file but ``models/default.yaml`` itself is read on
    top of another scenario: the one its ``base`` key names (:data:`BASE_KEY`), else the default
    scenario (whose fields equal the dataclasses' defaults:
    tests/diagrams/test_scenario_defaults.py). The fields a file names change; every other one is
    its base's."""
    path = scenario_path(name_or_path)
    scenario = Scenario()
    for file, data in reversed(_scenario_chain(path)):
        try:
            scenario = yaml_load_typed(schema=Scenario, data=yaml_dump(data) if data else "{}",
                                       defaults=scenario)
        except Exception as err:  # yaml and schema errors come as several exception types
            message = " ".join(str(err).split())
            raise ScenarioError(f"invalid scenario {file}: {message}") from None
    validate(scenario, path)
    resolve_model_paths(scenario)
    return scenario


def _scenario_chain(path: Path) -> list[tuple[Path, dict]]:
    """The file at ``path`` and the files it is read on top of, outermost first, down to
    ``models/default.yaml`` (always last), each with the fields it names (its ``base`` key
    taken out)."""
    default = scenario_path("default").resolve()
    chain: list[tuple[Path, dict]] = []
    while True:
        if not path.is_file():
            raise ScenarioError(f"scenario file not found: {path}"
                                + (f" (the base of {chain[-1][0]})" if chain else ""))
        if any(path.resolve() == file.resolve() for file, _ in chain):
            loop = " -> ".join(str(file) for file, _ in (*chain, (path, None)))
            raise ScenarioError(f"scenario files name each other as base: {loop}")
        data = _scenario_file_data(path)
        base = data.pop(BASE_KEY, None)
        chain.append((path, data))
        if path.resolve() == default:
            if base is not None:
                raise ScenarioError(f"invalid scenario {path}: the default scenario has no base")
            return chain
        path = scenario_path("default") if base is None else _base_path(base, path)


def _scenario_file_data(path: Path) -> dict:
    """The mapping a scenario file holds (empty for an empty file)."""
    try:
        with open(path, encoding="utf-8") as f:
            data: Any = yaml_load_data(f)
    except Exception as err:  # yaml errors come as several exception types
        message = " ".join(str(err).split())
        raise ScenarioError(f"invalid scenario {path}: {message}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ScenarioError(f"invalid scenario {path}: the file must hold a mapping of fields, "
                            f"not {type(data).__name__}")
    return data


def _base_path(base, path: Path) -> Path:
    """The file a scenario file at ``path`` names as its ``base``: a scenario name, or a path
    (relative paths from the file's folder)."""
    if not isinstance(base, str) or not base:
        raise ScenarioError(f"invalid scenario {path}: {BASE_KEY} must name a scenario or a "
                            f"scenario file, got {base!r}")
    if is_explicit_path(base) or base.endswith((".yaml", ".yml")):
        explicit = Path(base)
        return explicit if explicit.is_absolute() else path.parent / explicit
    return scenario_path(base)


# -- validation: one table of rules, one place ----------------------------------------------------
#
# Every scenario field is checked here before anything is built: a rule maps a dotted field path
# to a check that returns None (fine) or a short description of what is wrong. Non-finite numbers
# (``.nan``, ``.inf``) fail every numeric rule. Add a field's rule to FIELD_RULES (or a rule per
# list element with ``each``) next to the field; :func:`validate` reports every failing field in
# one line. Model files are checked by :func:`check_model_file` (exists, parses as XML).

Check = Callable[[Any], "str | None"]


def number(minimum: float | None = None, maximum: float | None = None,
           above: float | None = None) -> Check:
    """A finite real number with ``minimum <= value <= maximum`` and ``value > above``."""

    def check(value):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"must be a number (got {value!r})"
        if not math.isfinite(value):
            return f"must be finite (got {value})"
        if minimum is not None and value < minimum:
            return f"must be >= {minimum:g} (got {value:g})"
        if above is not None and not value > above:
            return f"must be > {above:g} (got {value:g})"
        if maximum is not None and value > maximum:
            return f"must be <= {maximum:g} (got {value:g})"
        return None

    return check


def each(size: int, element: Check | list[Check]) -> Check:
    """A list of ``size`` values, each passing ``element`` (or the i-th its own ``element[i]``)."""
    elements = element if isinstance(element, list) else [element] * size

    def check(values):
        if len(values) != size:
            return f"needs {size} values (got {len(values)})"
        for i, (value, rule) in enumerate(zip(values, elements, strict=True)):
            problem = rule(value)
            if problem:
                return f"[{i}] {problem}"
        return None

    return check


def one_of(*choices: str) -> Check:
    def check(value):
        return None if value in choices else f"{value!r} is not one of {', '.join(choices)}"

    return check


def _distribution(value):
    return one_of(*DISTRIBUTIONS)(value)


def _perception(value):
    return one_of(*PERCEPTIONS)(value)


def _integration_scheme(value):
    return one_of(*GetIntegrationSchemes())(value)


def check_model_file(name: str) -> str | None:
    """A model file that exists and is well-formed XML (URDF and SDFormat both are)."""
    try:
        path = model_path(name)
        ET.parse(path)
    except ModelFileError as err:
        return str(err)
    except (ET.ParseError, OSError, UnicodeDecodeError) as err:
        return f"malformed model file {name}: {' '.join(str(err).split())}"
    return None


MAX_RATE = 10_000.0  # Hz: a referee (and its arm loggers) faster than this is no table-tennis rate
# Joint friction and torque noise of the simulated arm, per joint, at most the joint's effort
# limit: Coulomb friction (or noise) beyond it holds the joint against every torque its motor can
# give, and viscous friction b with b (1 rad/s) beyond it stops every stroke (strokes move the
# joints at several rad/s). The smoothing velocity v_s of -c tanh(v / v_s) lies in
# [0.01, 10] rad/s (joint friction models smooth the sign change over 0.01-0.1 rad/s): the
# friction's slope at rest, c / v_s, makes the arm's equations stiff, and the integrator's error
# control shrinks its steps in proportion to v_s (docs/robustness.md); above 10 rad/s it is
# viscous friction. (N m, and N m s/rad for the viscous part.)
JOINT_FRICTION = each(7, [number(minimum=0.0, maximum=limit) for limit in EFFORT_LIMIT])
COULOMB_VELOCITY_RANGE = (0.01, 10.0)  # rad/s

FIELD_RULES: dict[str, Check] = {
    "world.plant.time_step": number(minimum=0.0, maximum=0.01),
    "world.plant.penetration_allowance": number(above=0.0),
    "world.plant.stiction_tolerance": number(above=0.0),
    "world.plant.contact_model": one_of("point", "hydroelastic", "hydroelastic_with_fallback"),
    "world.plant.discrete_contact_approximation": one_of("", "tamsi", "sap", "similar", "lagged"),
    "world.plant.sap_near_rigid_threshold": number(minimum=0.0),
    "world.plant.contact_surface_representation": one_of("triangle", "polygon"),
    "world.simulator.integration_scheme": _integration_scheme,
    "world.simulator.max_step_size": number(above=0.0, maximum=0.1),
    "world.simulator.accuracy": number(above=0.0, maximum=1.0),
    "world.simulator.start_time": number(minimum=0.0),
    "world.simulator.target_realtime_rate": number(minimum=0.0),
    "world.flight_accuracy": number(minimum=0.0, maximum=1.0),
    "world.joint_stops.natural_frequency": number(above=0.0, maximum=1e4),
    "world.joint_stops.dissipation": number(minimum=0.0, maximum=100.0),
    "world.models.table": check_model_file,
    "world.models.ball": check_model_file,
    "world.models.robot": check_model_file,
    "launcher.distribution": _distribution,
    "launcher.spin_max": number(minimum=0.0),
    "perception": _perception,
    "aerodynamics.drag_k": number(minimum=0.0),
    "aerodynamics.magnus_cl": number(minimum=0.0),
    "referee.target_x": number(),
    "referee.target_y": number(),
    "referee.target_radius": number(above=0.0),
    "referee.reward_sigma": number(above=0.0),
    "referee.return_floor": number(minimum=0.0, maximum=1.0),
    "referee.velocity_jump": number(above=0.0),
    "referee.racket_reach": number(above=0.0),
    "referee_rate": number(above=0.0, maximum=MAX_RATE),
    "rally.target_x": number(),
    "rally.target_y": number(above=0.0),
    "rally.flight_times": lambda v: (None if v and all(number(above=0.0)(t) is None for t in v)
                                     else "needs one or more numbers > 0"),
    "rally.max_exchanges": number(minimum=1, maximum=MAX_EXCHANGES),
    "rally.exchange_timeout": number(above=0.0, maximum=60.0),
    "rally.aim": one_of(*AIMS),
    "controller.kp": each(7, number(minimum=0.0, above=0.0)),
    "controller.ki": each(7, number(minimum=0.0)),
    "controller.kd": each(7, number(minimum=0.0, above=0.0)),
    "controller.mass_scale": number(minimum=0.1, maximum=10.0),
    "controller.inertia_scale": number(minimum=0.1, maximum=10.0),
    "controller.joint_viscous": JOINT_FRICTION,
    "controller.joint_coulomb": JOINT_FRICTION,
    "controller.coulomb_velocity": number(minimum=COULOMB_VELOCITY_RANGE[0],
                                          maximum=COULOMB_VELOCITY_RANGE[1]),
    "controller.torque_noise": JOINT_FRICTION,
    "controller.drive_voltage": lambda v: (
        number()(v) or (None if v == 0.0 or SUPPLY_VOLTAGE_RANGE[0] <= v <= SUPPLY_VOLTAGE_RANGE[1]
                        else f"must be 0 (ideal drives) or in the WAM supply's "
                             f"{SUPPLY_VOLTAGE_RANGE[0]:g}-{SUPPLY_VOLTAGE_RANGE[1]:g} V "
                             f"(got {v:g})")),
    "after_crossing": number(above=0.0, maximum=60.0),
    "teacher.min_hitting": number(minimum=0.0, maximum=StageTimes().hitting),
    "teacher.direct_lead": number(minimum=0.0, maximum=2.0),
    "teacher.ik_solver": one_of(*SOLVERS),
    "teacher.torque_fraction": number(above=0.0, maximum=2.0),
    "teacher.correction_torque_fraction": number(above=0.0, maximum=2.0),
    "teacher.awaiting_base": number(minimum=JOINT_LOWER[0] + JOINT_MARGIN,
                                    maximum=JOINT_UPPER[0] - JOINT_MARGIN),
    "learned.supply_fraction": number(above=0.0, maximum=3.0),
}


def _field(config, path: str):
    value = config
    for name in path.split("."):
        value = getattr(value, name)
    return value


def rule_problems(config, root: str = "") -> list[str]:
    """``path problem`` for every rule of :data:`FIELD_RULES` that ``config`` breaks: the whole
    scenario (``root`` empty) or the config at ``root`` (e.g. ``controller``)."""
    problems = []
    prefix = f"{root}." if root else ""
    for path, check in FIELD_RULES.items():
        if not path.startswith(prefix):
            continue
        try:
            value = _field(config, path[len(prefix):])
        except AttributeError:
            continue  # a field of a newer config that this object does not have
        problem = check(value)
        if problem:
            problems.append(f"{path} {problem}")
    return problems


def validate(scenario: Scenario, origin: object = "scenario") -> None:
    """Check every field of :data:`FIELD_RULES` (finite, sign, range, choices, model files);
    raise ScenarioError with one line naming each invalid field. Nothing invalid reaches Drake:
    ``load_scenario`` and ``ServeDiagram`` call this before building anything."""
    problems = [p for p in rule_problems(scenario)
                if scenario.world.with_robot or not p.startswith("world.models.robot ")]
    # The configs that also live outside scenarios check themselves (their cross-field ranges).
    problems += scenario.camera.problems()
    problems += scenario.rally.competitive.problems()
    problems += scenario.launcher.problems()
    problems += scenario.controller.combination_problems()
    if problems:
        raise ScenarioError(f"invalid scenario {origin}: " + "; ".join(problems))


def dump_scenario(scenario: Scenario) -> str:
    return yaml_dump_typed(scenario)
