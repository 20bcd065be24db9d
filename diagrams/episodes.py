"""Build the serve diagram for a scenario and a player, and run serve episodes on it.

The diagram (docs/design.md, "The serve diagram"): the station of one robot
(:mod:`tt_drake.diagrams.station`: BallLauncher, MultibodyPlant (WAM + racket, table, net, floor,
ball), Aerodynamics, Drake's InverseDynamicsController and the Referee) with the player wired to
its ports, and the episodes' loggers. It is built once; each episode restores a saved context
(``SetTimeStateAndParametersFrom`` + ``Initialize``, docs/design.md), sets the launcher's seed, puts
the ball at the launch state and simulates until the referee ends the episode (the ball reached the
floor) or, at the latest, the predicted crossing of the hitting plane plus
``Scenario.after_crossing``.

The players are registered in :mod:`tt_drake.diagrams.players` (the protocol of a player
function is there); the built-in players' functions are here.
"""

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink

from tt_drake.arm_metrics import arm_metrics
from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.constants import MAX_SEED, MAX_SERVES, PLANES
from tt_drake.diagrams.demonstrations import DemonstrationRecorder
from tt_drake.diagrams.players import (  # noqa: F401 (PlayerError: re-exported)
    PlayerError,
    WorldPorts,
    player_function,
    player_system,
)
from tt_drake.diagrams.scenario import Scenario, validate
from tt_drake.diagrams.station import (
    add_station,
    arm_port,
    awaiting_posture,
    reset_episode,
    station_ports,
)
from tt_drake.drives import drive_envelope
from tt_drake.errors import BadInputError
from tt_drake.estimation import EstimatorConfig
from tt_drake.hitting_point import HittingPointGPR, PhysicalPredictor, PredictorFileError
from tt_drake.hitting_time import HittingBand
from tt_drake.learned_player import (
    LearnedArtefactError,
    MoMPStroke,
    load_configuration_model,
    load_player_library,
)
from tt_drake.referee_rules import Outcome
from tt_drake.seeds import episode_seed  # noqa: F401  (re-exported: runners import it here)
from tt_drake.stages import HITTING, StageTimes
from tt_drake.systems.analytical_player import AnalyticalPlayer, PlannerConfig, StrokePlanner
from tt_drake.systems.ball_camera import BallCamera
from tt_drake.systems.ball_flight_estimator import BallFlightEstimator
from tt_drake.systems.ball_oracle import BallOracle
from tt_drake.systems.hitting_configuration import SOURCES, HittingConfiguration
from tt_drake.systems.hitting_ik import HittingIK
from tt_drake.systems.hitting_point_predictor import HittingPointPredictor
from tt_drake.systems.momp_player import MoMPTrajectorySource, momp_config
from tt_drake.systems.wam import SERVO_HOLD, add_servo_hold, hold_first_setpoint
from tt_drake.systems.world import World, advance_in_segments, simulator_and_schedule
from tt_drake.wam_params import AWAITING, SERVO_PERIOD

# The players' set-points are held for a servo tick; they evaluate their plans half a tick ahead.
SETPOINT_LEAD = 0.5 * SERVO_PERIOD


# Longest episode of a serve that never crosses the hitting plane (s): any ball reaches the
# floor sooner.
NO_CROSSING_DURATION = 3.0



def add_idle_player(builder: DiagramBuilder, world: World, controller, scenario: Scenario) -> list:
    """Hold the awaiting posture: constant desired state (q_await, 0) and zero acceleration."""
    q = np.asarray(AWAITING, dtype=float)
    desired = builder.AddNamedSystem("idle_player", ConstantVectorSource(np.r_[q, np.zeros(7)]))
    builder.Connect(desired.get_output_port(), controller.get_input_port_desired_state())
    accel = builder.AddNamedSystem("idle_acceleration", ConstantVectorSource(np.zeros(7)))
    builder.Connect(accel.get_output_port(), controller.get_input_port_desired_acceleration())
    return []


def add_perception(builder: DiagramBuilder, world: World, scenario: Scenario,
                   estimator_config=None):
    """What the players see, by ``scenario.perception``: ``camera`` (60 Hz, noisy) -> ball-flight
    estimator (with ``estimator_config``, default :class:`EstimatorConfig`), or ``oracle`` (the
    true ball state at the camera's frames, no noise). Returns (the systems that draw random
    numbers, the system with the estimator's output ports)."""
    if scenario.perception == "oracle":
        oracle = builder.AddNamedSystem("ball_oracle", BallOracle())
        builder.Connect(world.plant.get_state_output_port(world.ball), oracle.get_input_port(0))
        return [], oracle

    camera = builder.AddNamedSystem("ball_camera", BallCamera(scenario.camera))
    builder.Connect(world.plant.get_state_output_port(world.ball), camera.get_input_port(0))
    # The estimator knows the camera's noise (at least 0.5 mm, so that a noiseless camera's
    # innovation covariance stays invertible); frames carry their capture time (latency).
    estimator_config = dataclasses.replace(estimator_config or EstimatorConfig(),
                                           meas_sigma=max(scenario.camera.sigma, 5e-4))
    estimator = builder.AddNamedSystem("ball_flight_estimator",
                                       BallFlightEstimator(estimator_config))
    builder.Connect(camera.GetOutputPort("measurement"), estimator.GetInputPort("measurement"))
    return [camera], estimator


def teacher_planner_config(scenario: Scenario) -> PlannerConfig:
    """The teacher's planner for a scenario: aiming at its referee's target, with its
    ``teacher`` settings (:class:`tt_drake.diagrams.scenario.TeacherConfig`) and planning
    within its arm's drives (``controller.drive_voltage``)."""
    teacher = scenario.teacher
    return PlannerConfig(target_x=scenario.referee.target_x, target_y=scenario.referee.target_y,
                         correction_fallbacks=teacher.correction_fallbacks,
                         plan_fallbacks=teacher.plan_fallbacks,
                         torque_fraction=teacher.torque_fraction,
                         correction_torque_fraction=teacher.correction_torque_fraction,
                         drive_voltage=scenario.controller.drive_voltage,
                         times=StageTimes(min_hitting=teacher.min_hitting,
                                          direct_lead=teacher.direct_lead),
                         awaiting=(teacher.awaiting_base, *AWAITING[1:]),
                         posture_fallback=teacher.posture_fallback,
                         ik_solver=teacher.ik_solver)


def add_analytical_player(builder: DiagramBuilder, world: World, controller,
                          scenario: Scenario, player_type=None, config=None) -> list:
    """The teacher: camera -> estimator -> physical-model planner -> polynomial stages.
    ``player_type``: a subclass of AnalyticalPlayer to wire instead (the Gymnasium envs).
    ``config``: the planner's :class:`PlannerConfig` (default: aiming at the scenario's
    referee target)."""
    seeded, estimator = add_perception(builder, world, scenario)
    if config is None:
        config = teacher_planner_config(scenario)
    player = builder.AddNamedSystem("analytical_player",
                                    (player_type or AnalyticalPlayer)(StrokePlanner(config=config),
                                                                      setpoint_lead=SETPOINT_LEAD,
                                                                      setpoint_period=SERVO_PERIOD))
    builder.Connect(estimator.GetOutputPort("state"), player.GetInputPort("estimated_state"))
    if estimator.HasOutputPort("spin"):  # the oracle's (and the spin-aware EKF's)
        builder.Connect(estimator.GetOutputPort("spin"), player.GetInputPort("estimated_spin"))
    builder.Connect(estimator.GetOutputPort("status"), player.GetInputPort("estimator_status"))
    add_servo_hold(builder, player.GetOutputPort("setpoint"), controller)
    return seeded


# Artefacts loaded with ``keep`` (the CLI's check), by their files: the next load of the same files
# takes them instead of loading (and refitting CrKR) again; forked workers inherit them.
_CHECKED: dict = {}


def _artefact_key(scenario: Scenario, primitives: bool) -> tuple:
    cfg = scenario.learned
    files = []
    for path in (cfg.library if primitives else "", cfg.crkr, cfg.predictor):
        try:
            st = os.stat(path) if path else None
        except OSError:
            st = None
        files.append((path, None if st is None else (st.st_mtime_ns, st.st_size)))
    return (scenario.name, primitives, cfg.configuration, *files)


def load_learned_player(scenario: Scenario, primitives: bool = True, keep: bool = False) -> dict:
    """Load and check the learned player's artefacts named in ``scenario.learned`` (the
    primitive library only with ``primitives``); raise PlayerError with one line naming the
    problem (missing, corrupt, another scenario). With ``keep`` the artefacts are also kept for
    the next load of the same unchanged files, which takes them (one diagram owns them)."""
    cfg = scenario.learned
    if cfg.configuration not in SOURCES:
        raise PlayerError(f"unknown hitting configuration {cfg.configuration!r}; choose one of "
                          f"{', '.join(SOURCES)}")
    if primitives and not cfg.library:
        raise PlayerError("the momp player needs --library FILE (from tt-drake train library)")
    if cfg.configuration == "crkr" and not cfg.crkr:
        raise PlayerError("the learned player with --configuration crkr needs --crkr FILE (from "
                          "tt-drake train crkr)")
    key = _artefact_key(scenario, primitives)
    if key in _CHECKED:
        return _CHECKED[key] if keep else _CHECKED.pop(key)
    out = {}
    try:
        if primitives:
            out["library"], out["stages"], _ = load_player_library(
                cfg.library, scenario.name, PLANES.hitting_y)
        if cfg.configuration == "crkr":
            out["crkr"], _ = load_configuration_model(cfg.crkr, scenario.name, PLANES.hitting_y)
        out["gpr"] = HittingPointGPR.load(cfg.predictor) if cfg.predictor else None
    except (LearnedArtefactError, PredictorFileError) as err:
        raise PlayerError(str(err)) from None
    if out["gpr"] is not None and out["gpr"].estimator is None:
        raise PlayerError(f"{cfg.predictor}: the predictor has no saved estimator settings (the "
                          "filter it was trained on); train it again with tt-drake "
                          "train-predictor")
    if keep:
        _CHECKED[key] = out
    return out


def connect_hitting_chain(builder: DiagramBuilder, predictor, configuration, player) -> None:
    """Wire the learned player's chain by port name: the predicted virtual hitting point
    (``p_hit``, ``v_hit``, ``t_hit``, ``valid``, ``spin_hit``) into the hitting configuration and
    the player, the configuration (``theta_hit``, ``theta_dot_hit``, ``valid``) into the player."""
    for name in ("p_hit", "v_hit", "t_hit", "valid", "spin_hit"):
        builder.Connect(predictor.GetOutputPort(name), configuration.GetInputPort(name))
    for name in ("p_hit", "v_hit", "t_hit", "spin_hit"):
        builder.Connect(predictor.GetOutputPort(name), player.GetInputPort(name))
    for name in ("theta_hit", "theta_dot_hit"):
        builder.Connect(configuration.GetOutputPort(name), player.GetInputPort(name))
    builder.Connect(configuration.GetOutputPort("valid"),
                    player.GetInputPort("configuration_valid"))


def add_learned_player(builder: DiagramBuilder, world: World, controller, scenario: Scenario,
                       primitives: bool = True, band=None) -> list:
    """The learned player (paper Fig. 1): camera -> estimator -> GPR hitting-point predictor ->
    HittingConfiguration (CrKR or the analytical IK) -> MoMPTrajectorySource -> controller.

    Without ``primitives`` (the ``crkr`` player, paper section III-B.2) the trajectory source
    moves between the stages with the teacher's quintics instead of the motor primitives: the
    learned hitting configuration evaluated on its own. ``band``: where the moving goal's
    refreshed predictions may hit off the plane (:class:`tt_drake.hitting_time.HittingBand`;
    None: the default band, with the moving goal)."""
    learned = load_learned_player(scenario, primitives)
    # A GPR is fed the estimates of the filter it was trained on (docs/spin.md).
    gpr = learned["gpr"]
    seeded, estimator = add_perception(builder, world, scenario,
                                       gpr.estimator if gpr else None)
    # Early predictions start the MoMP player's preparation stage at detection (paper section
    # III-C). The crkr player (the teacher's quintic stages, section III-B.2) waits for the final
    # prediction: with ~0.5 s left at detection its stages leave no room for a preparation, so a
    # hitting stage begun on an early prediction would stay committed to it.
    # dt = 10 ms: the model locates the plane inside a step, so the step only sets RK4's error
    # (the crossing within 7e-9 m and 1.3e-9 s of a 0.25 ms step's;
    # docs/performance.md, "The players' Python").
    # After the robot-side bounce the estimator knows the spin: the MoMP player's prediction
    # follows the ball from there (docs/spin.md). One stateless physical predictor serves both.
    refresh = PhysicalPredictor(CompliantBounceBallModel(dt=1e-2)) if primitives else None
    early = refresh if scenario.learned.early_prediction else None
    # With the moving goal the refreshed predictions choose the hitting point as the teacher
    # does (the plane, else along the path: tt_drake.hitting_time).
    if band is None and scenario.learned.moving_goal:
        band = HittingBand()
    # With the moving goal on the stock robot the refresh starts before the bounce.
    ahead = scenario.learned.moving_goal and scenario.learned.refresh_before_bounce
    predictor = builder.AddNamedSystem("hitting_point_predictor", HittingPointPredictor(
        gpr=learned["gpr"], early=early, refresh=refresh, band=band, refresh_ahead=ahead))
    builder.Connect(estimator.GetOutputPort("state"), predictor.GetInputPort("state"))
    builder.Connect(estimator.GetOutputPort("spin"), predictor.GetInputPort("spin"))
    builder.Connect(estimator.GetOutputPort("status"), predictor.GetInputPort("status"))
    if scenario.learned.configuration == "crkr":
        configuration = HittingConfiguration("crkr", model=learned["crkr"])
    else:
        config = teacher_planner_config(scenario)
        # With the moving goal (the hard protocol) the teacher's aim gets the predicted spin.
        configuration = HittingConfiguration(
            "analytical", planner=StrokePlanner(config=config),
            use_spin=scenario.learned.moving_goal or scenario.learned.spin_aware)
    configuration = builder.AddNamedSystem("hitting_configuration", configuration)
    crkr = learned.get("crkr")
    player = builder.AddNamedSystem("momp_player", MoMPTrajectorySource(
        learned.get("library"), learned.get("stages"), arm=HittingIK(),
        setpoint_lead=SETPOINT_LEAD, setpoint_period=SERVO_PERIOD,
        stimulus=None if crkr is None else crkr.stimulus,
        config=momp_config(scenario.learned.moving_goal, scenario.controller.drive_voltage,
                           scenario.learned.correction_fallback,
                           scenario.learned.stroke_fallbacks,
                           scenario.learned.supply_fraction)))
    # The measured arm: the player holds when the arm no longer follows its plan.
    builder.Connect(world.plant.get_state_output_port(world.robot),
                    player.GetInputPort("arm_state"))
    connect_hitting_chain(builder, predictor, configuration, player)
    # The ball's index, by which a competitive stroke draws its aim (the rally's).
    builder.Connect(predictor.GetOutputPort("balls"), configuration.GetInputPort("balls"))
    if configuration.uses_spin and primitives:
        # A move refused with the spin-aware racket is tried with the spinless one.
        builder.Connect(configuration.GetOutputPort("theta_dot_hit_spinless"),
                        player.GetInputPort("theta_dot_hit_spinless"))
    if configuration.source == "analytical" and primitives:
        # A move refused with both racket velocities may be played as another of the teacher's
        # strokes (MoMPConfig.stroke_fallbacks).
        builder.Connect(configuration.GetOutputPort("fallback_strokes"),
                        player.GetInputPort("fallback_strokes"))
    add_servo_hold(builder, player.GetOutputPort("setpoint"), controller)
    return seeded


def add_momp_player(builder: DiagramBuilder, world: World, controller,
                    scenario: Scenario) -> list:
    """The ``momp`` player: :func:`add_learned_player` with the motor primitives."""
    return add_learned_player(builder, world, controller, scenario, primitives=True)


def add_crkr_player(builder: DiagramBuilder, world: World, controller,
                    scenario: Scenario) -> list:
    """The ``crkr`` player: :func:`add_learned_player` with the teacher's quintic stages."""
    return add_learned_player(builder, world, controller, scenario, primitives=False)


def check_momp_artefacts(scenario: Scenario) -> None:
    """Load and check the ``momp`` player's artefacts, kept for the diagram built next
    (:func:`load_learned_player` with ``keep``)."""
    load_learned_player(scenario, primitives=True, keep=True)


def check_crkr_artefacts(scenario: Scenario) -> None:
    """Load and check the ``crkr`` player's artefacts (no primitive library), kept for the
    diagram built next."""
    load_learned_player(scenario, primitives=False, keep=True)


@dataclass
class EpisodeResult:
    seed: int
    launch_state: list[float]
    predicted_crossing: list[float]
    duration: float
    outcome: Outcome
    wall_time: float
    ball_path: np.ndarray | None = field(default=None, repr=False)
    arm: dict | None = None
    record: dict | None = field(default=None, repr=False)  # demonstration data (collect)
    stroke: dict | None = None  # the learned player's last plan (stroke_summary)
    # CPU time of the thread that ran the episode (thread_time, s, measured inside the wall
    # interval, so never more than wall_time): with wall_time, how much of a core a worker got
    # (tt-drake bench --workers; not written to the JSON).
    cpu_time: float = 0.0

    def as_dict(self) -> dict:
        return {
            "seed": self.seed,
            "launch_state": [round(float(c), 5) for c in self.launch_state],
            "predicted_crossing": [round(float(c), 5) if np.isfinite(c) else None
                                   for c in self.predicted_crossing],  # None: no crossing
            "duration": round(self.duration, 4),
            "wall_time": round(self.wall_time, 4),
            **self.outcome.as_dict(),
            **({"arm": self.arm} if self.arm is not None else {}),
            **({"stroke": self.stroke} if self.stroke is not None else {}),
        }


def stroke_summary(stroke) -> dict | None:
    """The learned player's last (re-)plan of an episode, for JSON: the stimulus it used, which
    hitting primitives carried the stroke with their mixture weights nu_i (Eq. 6), how many
    re-plans, and whether it fell back to the teacher's quintics (None for other players)."""
    if not isinstance(stroke, MoMPStroke):
        return None
    return {"stimulus": [round(float(c), 5) for c in stroke.stimulus],
            "t_hit": round(float(stroke.t_hit), 5),
            "theta_hit": [round(float(c), 6) for c in stroke.q_hit],
            "theta_dot_hit": [round(float(c), 6) for c in stroke.qd_hit],
            "primitives": [int(i) for i in stroke.primitives],
            "mixture": [round(float(w), 6) for w in stroke.mixture],
            "replans": int(stroke.replans), "fallback": bool(stroke.fallback),
            **({"held": True} if stroke.held else {}),
            **({"spinless": True} if stroke.spinless else {}),
            **({"teacher_stroke": True} if stroke.configuration is not None else {})}


class ServeDiagram:
    """The serve diagram of one scenario and player, built once and reused for every episode."""

    def __init__(self, scenario: Scenario, player: str | Callable = "idle",
                 log_ball: bool = False, record: bool = False,
                 end_when_decided: bool | None = None, log_setpoints: bool = False):
        """``player``: a registered name (:mod:`tt_drake.diagrams.players`), or a player
        function (tools: ``tt-drake bench`` replays set-points with one). ``log_setpoints``: log
        the servo holds' outputs (the set-points the controller got) at every tick, for
        :meth:`setpoints`."""
        add_player = player_function(player)
        validate(scenario)  # nothing invalid reaches Drake, whoever built the scenario
        self.scenario = scenario
        # The referee ends an episode once the return's outcome is decided, except when the
        # whole stroke is wanted: demonstrations (the return to the awaiting posture is one).
        # A recording (``log_ball``) ends it as an unrecorded run does, and is extended after the
        # result is taken (:meth:`extend`): recording is observation only.
        self.end_when_decided = not record if end_when_decided is None else end_when_decided
        builder = DiagramBuilder()
        parts = station = self.station = add_station(
            builder, scenario, robots=int(scenario.world.with_robot),
            end_when_decided=self.end_when_decided)
        self.world, self.launcher, self.referee = parts.world, parts.launcher, parts.referee
        self.controller = self.arm_logger = self.torque_logger = None
        self.seeded = [self.launcher]
        period = 1.0 / scenario.referee_rate
        # What the player and the loggers read: the station's ports.
        world = WorldPorts(station.GetOutputPort("ball_state"))
        if self.world.robot is not None:
            world, self.controller = station_ports(station)
            self.seeded += add_player(builder, world, self.controller, scenario)
            self.seeded += parts.seeded  # the arm's torque noise
            # Arm state and commanded torques at the referee's rate (aligned events: no extra
            # integrator stops), for joint-limit and saturation metrics.
            self.arm_logger = builder.AddNamedSystem("arm_logger", VectorLogSink(14, period))
            builder.Connect(station.GetOutputPort(arm_port(0, "state")),
                            self.arm_logger.get_input_port())
            self.torque_logger = builder.AddNamedSystem("torque_logger", VectorLogSink(7, period))
            builder.Connect(station.GetOutputPort(arm_port(0, "torque")),
                            self.torque_logger.get_input_port())
        self.setpoint_logs = []
        if log_setpoints and builder.HasSubsystemNamed(SERVO_HOLD):
            log = builder.AddNamedSystem("setpoint_logger", VectorLogSink(21, SERVO_PERIOD))
            builder.Connect(builder.GetSubsystemByName(SERVO_HOLD).get_output_port(),
                            log.get_input_port())
            self.setpoint_logs.append(log)
        self.player = player_system(builder)
        # When the learned player's hitting stage began, was the prediction out the GPR's final
        # one or an early physical-model one? Logged at the referee's rate (no new event time).
        self.final_logger = None
        if (builder.HasSubsystemNamed("momp_player")
                and builder.HasSubsystemNamed("hitting_point_predictor")):
            self.final_logger = builder.AddNamedSystem("prediction_final_logger",
                                                       VectorLogSink(1, period))
            builder.Connect(builder.GetSubsystemByName("hitting_point_predictor")
                            .GetOutputPort("final"), self.final_logger.get_input_port())
        self.recorder = None
        if record:
            self.recorder = DemonstrationRecorder(builder, world, scenario)
        self.ball_logger = self.estimate_logger = self.prediction_logger = None
        if log_ball:
            # Every recording logger samples at the referee's rate: no event time the unrecorded
            # diagram lacks, so the error-controlled integrator takes the same steps.
            self.ball_logger = builder.AddNamedSystem("ball_logger", VectorLogSink(13, period))
            builder.Connect(station.GetOutputPort("ball_state"),
                            self.ball_logger.get_input_port())
            # What the robot believes: the estimated path and the predicted hitting point.
            if builder.HasSubsystemNamed("ball_flight_estimator"):
                estimator = builder.GetSubsystemByName("ball_flight_estimator")
                self.estimate_logger = builder.AddNamedSystem(
                    "estimate_logger", VectorLogSink(6, period))
                builder.Connect(estimator.GetOutputPort("state"),
                                self.estimate_logger.get_input_port())
                self.status_logger = builder.AddNamedSystem(
                    "estimate_status_logger", VectorLogSink(2, period))
                builder.Connect(estimator.GetOutputPort("status"),
                                self.status_logger.get_input_port())
            if self.player is not None:
                self.prediction_logger = builder.AddNamedSystem(
                    "prediction_logger", VectorLogSink(4, period))
                builder.Connect(self.player.GetOutputPort("predicted_hit"),
                                self.prediction_logger.get_input_port())
        self.diagram = builder.Build()
        self.diagram.set_name("serve_diagram")
        # The episodes decide the integrator's accuracy once per referee tick (advance_in_segments)
        # rather than through the simulator's monitor after every step; the monitor (the same
        # schedule) stays attached for whoever steps this simulator directly.
        self.simulator, self._schedule = simulator_and_schedule(self.diagram, scenario.world,
                                                                self.world.plant)
        self._segment = period
        self.context = self.simulator.get_mutable_context()
        self._set_awaiting_posture()
        self._initial = self.context.Clone()

    def _set_awaiting_posture(self) -> None:
        """The servo holds (if any) holding the player's first set-point, so that nothing sees
        their default zeros before the first tick, and the arm at rest where it asks (its
        awaiting posture)."""
        if self.world.robot is None:
            return
        hold_first_setpoint(self.diagram, self.context)
        awaiting_posture(self.world, self.context, self.station)

    @property
    def library(self):
        """The momp player's primitive library (None for other players)."""
        return getattr(self.player, "library", None)

    def run(self, seed: int, gamma=None, weights=None) -> EpisodeResult:
        """Simulate one serve episode from ``seed``, from t = 0 (a recording places it on its
        own timeline afterwards). ``gamma``: the momp player's responsibilities for this episode
        (default: the loaded library's); ``weights``: its hitting primitives' weights ``(P, D,
        B)`` for this episode (PoWER's explored weights; default: the loaded library's)."""
        wall = time.perf_counter()
        cpu = time.thread_time()
        self._set_library_array("gamma", gamma, lambda g: np.all(g >= 0) and np.any(g > 0),
                                "responsibilities gamma",
                                lambda g0: f"gamma must be {g0.shape[0]} non-negative values, "
                                           "not all zero")
        self._set_library_array("weights", weights, lambda w: np.all(np.isfinite(w)),
                                "primitive weights",
                                lambda w0: f"primitive weights must be {w0.shape} finite values")
        serve = reset_episode(self.simulator, self._initial, self.scenario.world.simulator,
                              self.seeded, self.world, seed)
        for logger in self._loggers():
            logger.FindMutableLog(self.context).Clear()
        if self.recorder is not None:
            self.recorder.clear(self.context)
        # A serve the model predicts never to cross the hitting plane (possible with a custom
        # launcher) is simulated until the ball reaches the floor, NO_CROSSING_DURATION at most.
        max_duration = (float(serve.crossing.t + self.scenario.after_crossing)
                        if serve.crossing is not None else NO_CROSSING_DURATION)
        self.simulator.Initialize()
        self.advance(max_duration)  # the referee may end it earlier
        self._end = max_duration
        duration = self.context.get_time()
        outcome = self.referee.GetOutputPort("outcome").Eval(
            self.referee.GetMyContextFromRoot(self.context))
        path = None
        if self.ball_logger is not None:
            path = self.ball_logger.FindLog(self.context).data()[4:7].T.copy()
            self.beliefs = self._beliefs()
        arm = None
        if self.controller is not None:
            x = self.arm_logger.FindLog(self.context).data().T
            tau = self.torque_logger.FindLog(self.context).data().T
            arm = arm_metrics(x[:, :7], x[:, 7:], tau,
                              drive_envelope(self.scenario.controller.drive_voltage))
        crossing = (np.r_[serve.crossing.position, serve.crossing.velocity, serve.crossing.t]
                    if serve.crossing is not None else np.full(7, np.nan))
        record = None
        if self.recorder is not None:
            record = self.recorder.extract(self.diagram, self.context, outcome)
        stroke = None
        if self.player is not None:
            stroke = stroke_summary(self.player.GetOutputPort("stroke").Eval(
                self.player.GetMyContextFromRoot(self.context)))
            if stroke is not None and self.final_logger is not None:
                stroke["early_prediction"] = self._hit_on_early_prediction()
        cpu = time.thread_time() - cpu
        return EpisodeResult(seed, list(serve.launch_state), list(crossing), duration, outcome,
                             time.perf_counter() - wall, path, arm, record, stroke, cpu)

    def extend(self, seconds: float) -> None:
        """Simulate the last episode up to ``seconds`` longer (never past its time limit, nor
        past the ball reaching the floor), after :meth:`run` took its result: a recording shows
        the ball's flight after the decided landing. Changes no result already returned."""
        end = min(self.context.get_time() + seconds, self._end)
        if end > self.context.get_time():
            self.advance(end)

    def advance(self, end: float):
        """Simulate to ``end``, or until a system ends the episode (the referee), with the
        accuracy decided once per referee tick (:func:`advance_in_segments`) as the episodes
        do: whoever continues an episode (the Gymnasium envs) gets the same numbers. Returns
        the simulator's status (``AdvanceTo``'s)."""
        if self._schedule is None:
            return self.simulator.AdvanceTo(end)
        return advance_in_segments(self.simulator, self._schedule, end, self._segment)

    def poses(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The logged times (K,), ball positions (K, 7: quaternion w, x, y, z, then p) and arm
        joint angles (K, 7, or None without a robot) of the last episode; needs ``log_ball``."""
        if self.ball_logger is None:
            raise PlayerError("poses are logged only with log_ball=True")
        log = self.ball_logger.FindLog(self.context)
        times, ball = log.sample_times().copy(), log.data()[:7].T.copy()
        arm = None
        if self.controller is not None:
            arm = self.arm_logger.FindLog(self.context).data()[:7].T.copy()
            k = min(len(arm), len(times))
            times, ball, arm = times[:k], ball[:k], arm[:k]
        return times, ball, arm

    def _hit_on_early_prediction(self) -> bool:
        """Whether the learned player's hitting stage began before the predictor's final (GPR)
        prediction was out, i.e. on an early physical-model one (to the referee's period)."""
        plan = self.player.player_state(self.player.GetMyContextFromRoot(self.context)).plan
        start = next((seg.t0 for stage, seg in plan.segments if stage == HITTING), None)
        if start is None:
            return False
        log = self.final_logger.FindLog(self.context)
        before = log.sample_times() <= start + 1e-9
        return not bool(np.any(log.data()[0, before] > 0.5))

    def _set_library_array(self, name: str, value, valid, what: str, invalid) -> None:
        """Set the momp library's array ``name`` (``gamma`` or ``weights``) for one episode:
        ``None`` restores the library's own (kept at the first call); else ``value`` must have
        its shape and pass ``valid`` (else PlayerError ``invalid(original)``)."""
        library = self.library
        if library is None:
            if value is not None:
                raise PlayerError(f"{what} apply to the momp player only")
            return
        originals = self.__dict__.setdefault("_library_arrays0", {})
        original = originals.setdefault(name, getattr(library, name).copy())
        a = original if value is None else np.asarray(value, dtype=float)
        if a.shape != original.shape or not valid(a):
            raise PlayerError(invalid(original))
        setattr(library, name, a.copy())

    def _beliefs(self) -> dict:
        """Estimated ball path and predicted hitting points (with their times) of the episode."""
        out = {}
        if self.estimate_logger is not None:
            x = self.estimate_logger.FindLog(self.context).data().T
            tracking = self.status_logger.FindLog(self.context).data()[0] > 0.5
            out["estimated_path"] = x[tracking & np.all(np.isfinite(x[:, :3]), axis=1), :3]
        if self.prediction_logger is not None:
            log = self.prediction_logger.FindLog(self.context)
            x = log.data().T
            valid = x[:, 3] > 0.5
            out["prediction_times"] = log.sample_times()[valid]
            out["predictions"] = x[valid, :3]
        return out

    def _loggers(self) -> list:
        loggers = [self.ball_logger] if self.ball_logger is not None else []
        loggers += [log for log in (self.estimate_logger, self.prediction_logger) if log]
        if self.estimate_logger is not None:
            loggers.append(self.status_logger)
        if self.controller is not None:
            loggers += [self.arm_logger, self.torque_logger]
        if self.final_logger is not None:
            loggers.append(self.final_logger)
        return loggers + self.setpoint_logs

    def setpoints(self) -> tuple[np.ndarray, np.ndarray]:
        """The last episode's servo ticks (K,) and the set-points (K, 21: q, q_dot, q_ddot) the
        servo held from each; needs ``log_setpoints``."""
        if not self.setpoint_logs:
            raise PlayerError("set-points are logged only with log_setpoints=True and a player "
                              "that drives the servo holds")
        log = self.setpoint_logs[0].FindLog(self.context)
        # A log entry at tick k is published before that tick's update: it holds the set-point
        # of tick k - 1.
        return log.sample_times()[:-1].copy(), log.data().T[1:].copy()


class SeedError(ValueError, BadInputError):
    """A base seed or serve count outside its range."""


def check_run(seed: int, serves: int | None = None) -> None:
    """Refuse a base seed outside [0, MAX_SEED] or a serve count outside [1, MAX_SERVES]
    before anything is simulated or written."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not (
            0 <= seed <= MAX_SEED):
        raise SeedError(f"seed must be a whole number in [0, {MAX_SEED}], got {seed!r}")
    if serves is not None and (isinstance(serves, bool) or not isinstance(
            serves, (int, np.integer)) or not 1 <= serves <= MAX_SERVES):
        raise SeedError(f"serves must be a whole number in [1, {MAX_SERVES}], got {serves!r}")


def summarize(results: list[EpisodeResult]) -> dict:
    n = len(results)
    summary = {
        "serves": n,
        "hit_rate": sum(r.outcome.hit for r in results) / n if n else 0.0,
        "return_rate": sum(r.outcome.returned for r in results) / n if n else 0.0,
        "target_rate": sum(r.outcome.on_target for r in results) / n if n else 0.0,
        "mean_reward": sum(r.outcome.reward for r in results) / n if n else 0.0,
        "double_bounce_faults": sum(r.outcome.hit and "double_bounce" in r.outcome.faults
                                    for r in results),
    }
    arms = [r.arm for r in results if r.arm is not None]
    if arms:
        summary["joint_limit_violations"] = sum(a["joint_limit_excess"] > 0 for a in arms)
        summary["max_joint_speed"] = max(a["max_joint_speed"] for a in arms)
        summary["episodes_with_saturation"] = sum(a["saturated_fraction"] > 0 for a in arms)
        summary["robot_table_contacts"] = sum("robot_table" in r.outcome.faults for r in results)
    strokes = [r.stroke for r in results if r.stroke is not None]
    if strokes:
        summary["fallback_strokes"] = sum(s["fallback"] for s in strokes)
    return summary
