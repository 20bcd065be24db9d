"""Gymnasium environments over the serve diagram (registered by :mod:`tt_drake.gym`).

Both are runners (docs/design.md): they build the serve diagram of
:class:`tt_drake.diagrams.episodes.ServeDiagram` once, with a player that lets an agent act, and
run serve episodes on it. Options (keyword arguments of ``gymnasium.make``): ``scenario`` (a
name in models/, a YAML path or a :class:`Scenario`), ``distribution`` (overrides the launcher's
serve distribution: ``default``, ``spin``, ``real``, ``fixed``, ...), ``reward`` (``referee``,
the default, or ``shaped``), ``render_mode`` (None, ``rgb_array`` or ``human``) and ``html``
(the ``human`` page's path). ``reset(seed=...)`` seeds the environment's generator, which draws
the serve's seed (camera noise included, as ``ServeDiagram.run``); ``reset(options={"serve_seed":
k})`` replays serve ``k`` whatever the generator says. The same seed gives the same observation,
and the same actions the same reward. Spaces are float32. An action with a NaN or infinite entry
raises ValueError naming the action, in both environments, before anything is simulated.

``tt_drake/ReturnBall-v0`` (:class:`ReturnBallEnv`): episodic, one serve per episode and one
step per episode, in the black-box style of fancy_gym's table-tennis tasks. ``action`` chooses
the mode:

``"offset"`` (default): the analytical player (the teacher) tracks the ball and plans its
stroke; ``reset`` simulates until it commits to the stroke (the planning tick at which the
hitting stage has begun: it re-plans no more, paper section III-A) and returns what it then
knows. ``step(action)`` changes the stroke's end, plays it and the rest of the episode, and
returns the paper's reward; ``terminated`` is always True.

- observation (10): the predicted hitting point p_hit (m, world frame), the ball's velocity there
  v_hit (m/s), the time left until the hit t_hit - t (s), and the spin the planner predicts there
  omega_hit (rad/s).
- action (14) in [-1, 1]: the offset to the analytical hitting configuration,
  theta_hit += a[:7] * max_position_offset (rad, default 0.1) and
  theta_dot_hit += a[7:] * max_velocity_offset (rad/s, default 1.0), clipped to the joint limits
  (both bounds finite and > 0). An action of zeros plays the analytical player's stroke, bit for
  bit.

``"absolute"``: learning from scratch, no teacher inside
(:class:`tt_drake.systems.gym_players.AbsoluteStrokePlayer`). The arm waits at the awaiting
posture; ``reset`` simulates until the estimator's ball has crossed the net toward the robot and
returns the estimate and the hittable window (:func:`tt_drake.systems.gym_players.hittable_window`:
from the bounce on the robot's half to where the ball comes down to the table's height again, so
that it bounces once on the robot's half before the hit). The action chooses the whole stroke's
end, which the stage planner plays from the awaiting posture (swing-back, hit, follow-through,
return).

- observation (18): the estimated ball p (m), v (m/s), spin (rad/s); the window's start and end
  from now (s); the predicted crossing of the virtual hitting plane inside the window: p, v and
  its time from now (zeros if it is not in the window).
- action (15) in [-1, 1]: theta_hit = centre + a[:7] * half range of each joint (its limits
  less the planner's 0.05 rad margin), theta_dot_hit = a[7:14] * velocity limit (10 rad/s),
  t_hit = start + (a[14] + 1) / 2 * (end - start) in the window.

Both modes:

- reward: the referee's (:mod:`tt_drake.referee_rules`): 0 missed, 0.2 hit but not returned,
  0.3 + 0.7 exp(-d^2 / (2 sigma^2)) for a legal return landing d from the target, at most 0.1 if
  the robot touched the table. With ``reward="shaped"``: the same for a hit, and for a missed
  ball SHAPING_MAX exp(-d / SHAPING_LENGTH) (at most 0.1) of the closest racket-centre-to-ball
  distance d on the robot's half, also in ``info["closest_approach"]``.
- ``info["is_success"]``: the return landed on the opponent's half within ``target_radius``
  (0.2 m) of the target (fancy_gym's definition); ``info["outcome"]`` the referee's verdict.

If the player never decides (offset: it found no stroke it could play; absolute: no window),
``reset`` has already simulated the whole episode: the observation is zeros,
``info["committed"]`` is False and ``step`` returns the outcome without playing the action.

``tt_drake/ReturnBallStep-v0`` (:class:`ReturnBallStepEnv`): step-based, on Drake's
``pydrake.gym.DrakeGymEnv``. The agent moves the arm's joint set-points at ``control_rate`` Hz
(default 100; finite, >= 50 and a divisor of the servo rate) through
:class:`tt_drake.systems.gym_players.SetpointIncrementPlayer`; the InverseDynamicsController tracks
them as it tracks the players'. A step's action takes effect one servo tick (2 ms) into the step
and lasts one control period.

- observation (22): the arm's state q (rad), q_dot (rad/s); the estimator's ball state p (m),
  v (m/s) (zeros until it tracks the ball), its status: tracking (0/1) and the time of the
  estimate (s, episode time).
- action (7) in [-1, 1]: set-point increments, a * (velocity limit / control_rate) rad per step.
- reward: 0 on every step but the last, which gets the episode's reward (as above, ``referee``
  or ``shaped``); the episode terminates when the referee decides the outcome (the return landed,
  hit the net or fell; a missed ball at the floor) and is truncated at the predicted crossing of
  the hitting plane plus ``Scenario.after_crossing`` (the serve episode's end). ``info`` holds
  ``is_success`` and ``outcome`` on the last step.

With ``player`` (a name registered in :mod:`tt_drake.diagrams.players`, e.g. ``analytical``
or one's own) that player drives the arm and the action offsets its desired joint positions
instead (a residual policy, :class:`tt_drake.systems.gym_players.SetpointOffset`): the offset
moves by a * (velocity limit / control_rate) rad per step, each joint's within +-0.5 rad, and
starts at zero each episode. The observation and the reward are as above.

Rendering (:mod:`tt_drake.diagrams.gym_render`, observation only): ``rgb_array`` renders the
arm and the ball as they are now with Drake's VTK engine, offscreen; ``human`` adds every
finished episode to a Meshcat recording that ``render()`` (and nothing else) writes to ``html``.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import gymnasium as gym
import numpy as np
from pydrake.gym import DrakeGymEnv
from pydrake.systems.primitives import Adder

from tt_drake.diagrams.episodes import (
    SETPOINT_LEAD,
    EpisodeResult,
    ServeDiagram,
    add_analytical_player,
    add_perception,
)
from tt_drake.diagrams.gym_render import EpisodePages, FrameRenderer
from tt_drake.diagrams.players import ControllerPorts, check_player, player_function
from tt_drake.diagrams.scenario import Scenario, load_scenario, validate
from tt_drake.diagrams.station import reset_episode
from tt_drake.referee_rules import Outcome
from tt_drake.systems.gym_players import (
    AbsoluteStrokePlayer,
    SetpointIncrementPlayer,
    SetpointOffset,
    StepObservation,
    StrokeOffsetPlayer,
)
from tt_drake.systems.referee import RacketCentre
from tt_drake.systems.wam import RACKET_CENTER_FRAME, add_servo_hold
from tt_drake.wam_params import SERVO_PERIOD, SERVO_RATE

OBSERVATION_FIELDS = ("p_hit_x", "p_hit_y", "p_hit_z", "v_hit_x", "v_hit_y", "v_hit_z",
                      "time_to_hit", "spin_x", "spin_y", "spin_z")
#: Bounds of ReturnBall-v0's observation (time to hit from 0): observations are clipped to them.
OBSERVATION_HIGH = np.r_[np.full(3, 5.0), np.full(3, 50.0), 5.0, np.full(3, 1000.0)]
OBSERVATION_LOW = np.r_[-OBSERVATION_HIGH[:6], 0.0, -OBSERVATION_HIGH[7:]]
ABSOLUTE_OBSERVATION_FIELDS = ("ball_x", "ball_y", "ball_z", "ball_vx", "ball_vy", "ball_vz",
                               "spin_x", "spin_y", "spin_z", "window_start", "window_end",
                               "plane_x", "plane_y", "plane_z", "plane_vx", "plane_vy",
                               "plane_vz", "plane_time")
#: Bounds of the absolute mode's observation (times from 0).
ABSOLUTE_HIGH = np.r_[np.full(3, 5.0), np.full(3, 50.0), np.full(3, 1000.0), 5.0, 5.0,
                      np.full(3, 5.0), np.full(3, 50.0), 5.0]
ABSOLUTE_LOW = np.r_[-ABSOLUTE_HIGH[:9], 0.0, 0.0, -ABSOLUTE_HIGH[11:17], 0.0]
STEP_OBSERVATION_FIELDS = (tuple(f"q{i}" for i in range(1, 8))
                           + tuple(f"qd{i}" for i in range(1, 8))
                           + ("ball_x", "ball_y", "ball_z", "ball_vx", "ball_vy", "ball_vz",
                              "tracking", "estimate_time"))

ACTION_MODES = ("offset", "absolute")
REWARDS = ("referee", "shaped")
RENDER_MODES = ["rgb_array", "human"]
#: The shaped reward of an episode whose ball the racket missed (``reward="shaped"``):
#: SHAPING_MAX exp(-d / SHAPING_LENGTH), d the closest racket-centre-to-ball distance on the
#: robot's half (m). Below the referee's 0.2 for a hit, so that any hit still scores more. An
#: exponential, not a Gaussian: its slope is still 1/e^4 of the peak's at 1 m, where a random
#: stroke's racket passes (a Gaussian of the blade's width is flat there).
SHAPING_MAX = 0.1
SHAPING_LENGTH = 0.25  # m


def make_scenario(scenario: str | Scenario = "default", distribution: str | None = None
                  ) -> Scenario:
    """The scenario the options name: a Scenario, or a name/path for :func:`load_scenario`, with
    the launcher's distribution replaced by ``distribution`` (checked: ScenarioError; a world
    without the robot: ValueError)."""
    base = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    if distribution is not None:
        launcher = dataclasses.replace(base.launcher, distribution=distribution)
        base = dataclasses.replace(base, launcher=launcher)
    validate(base)
    if not base.world.with_robot:
        raise ValueError("the Gymnasium environments need a scenario with the robot")
    return base


def _choice(name: str, value, choices) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}, not {value!r}")


def checked_action(action, size: int) -> np.ndarray:
    """The action as ``size`` floats clipped to [-1, 1]; a NaN or infinite entry raises
    ValueError naming the action (a NaN would otherwise reach the planner, or be read as 0)."""
    a = np.asarray(action, dtype=float).reshape(size)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"the action must be finite, got {a.tolist()}")
    return np.clip(a, -1.0, 1.0)


def shaped_reward(outcome: Outcome, closest: float) -> float:
    """The referee's reward for a hit; for a missed ball SHAPING_MAX exp(-d / SHAPING_LENGTH),
    d = ``closest`` (m; inf: 0)."""
    if outcome.hit:
        return float(outcome.reward)
    return SHAPING_MAX * math.exp(-closest / SHAPING_LENGTH)


def _serve_seed(env: gym.Env, options: dict | None) -> int:
    """The serve of this episode: ``options["serve_seed"]``, else drawn from ``env.np_random``."""
    if options and options.get("serve_seed") is not None:
        return int(options["serve_seed"])
    return int(env.np_random.integers(0, 2**32))


def _outcome_info(outcome: Outcome, serve_seed: int) -> dict:
    return {"is_success": bool(outcome.on_target), "outcome": outcome.as_dict(),
            "serve_seed": serve_seed}


class _ServeEnv:
    """What both environments share: the reward option, the episode's end (reward and info)
    and rendering, over ``self.serve_diagram`` (built by the subclass with
    ``log_ball=self._logs_poses``)."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 30}

    def _init_serve_env(self, reward: str, render_mode: str | None, html: str) -> None:
        _choice("reward", reward, REWARDS)
        _choice("render_mode", render_mode, [None, *RENDER_MODES])
        self.reward_mode, self.render_mode, self.html = reward, render_mode, str(html)
        self._renderer = None
        self._pages = None
        self._centre = None

    @property
    def _logs_poses(self) -> bool:
        """The ball's poses are logged (at the referee's rate, observation only) for the shaped
        reward's distance and the ``human`` pages."""
        return self.reward_mode == "shaped" or self.render_mode == "human"

    def _closest_approach(self) -> float:
        """The closest racket-centre-to-ball distance (m) of the episode so far, over the logged
        samples (250 Hz) with the ball on the robot's half (y < 0); inf if there is none."""
        diagram = self.serve_diagram
        if self._centre is None:
            plant, robot = diagram.world.plant, diagram.world.robot
            self._centre = RacketCentre(plant, robot,
                                        plant.GetFrameByName(RACKET_CENTER_FRAME, robot))
        _, ball, arm = diagram.poses()
        p = ball[: len(arm), 4:7]
        near = p[:, 1] < 0.0
        if not near.any():
            return math.inf
        racket = np.array([self._centre(q) for q in arm[near]])
        return float(np.linalg.norm(racket - p[near], axis=1).min())

    def _episode_end(self, outcome: Outcome, serve_seed: int, start: EpisodeResult | None):
        """The episode's reward and info (``info["closest_approach"]`` with the shaped reward);
        in ``human`` mode the episode joins the page."""
        info = _outcome_info(outcome, serve_seed)
        reward = float(outcome.reward)
        if self.reward_mode == "shaped":
            info["closest_approach"] = self._closest_approach()
            reward = shaped_reward(outcome, info["closest_approach"])
        if self.render_mode == "human" and start is not None:
            if self._pages is None:
                self._pages = EpisodePages(self.scenario, self.html, type(self).__name__)
            diagram = self.serve_diagram
            result = dataclasses.replace(start, outcome=outcome,
                                         duration=diagram.context.get_time())
            self._pages.add(result, diagram.poses())
        return reward, info

    def close(self) -> None:
        """Release the frame renderer (Drake's VTK render engine), here rather than whenever the
        garbage collector finds it."""
        self._renderer = None
        super().close()

    def render(self):
        """``rgb_array``: the arm and the ball now, (H, W, 3) uint8 (:class:`FrameRenderer`);
        ``human``: writes the Meshcat page of the episodes so far to ``html`` (nothing before
        the first episode ends) and returns None, as Gymnasium asks; no render mode: None."""
        if self.render_mode == "rgb_array":
            if self._renderer is None:
                self._renderer = FrameRenderer(self.scenario.world)
            world = self.serve_diagram.world
            plant_context = world.plant.GetMyContextFromRoot(self.serve_diagram.context)
            return self._renderer.frame(world.plant.GetPositions(plant_context, world.robot),
                                        world.plant.GetPositions(plant_context, world.ball))
        if self.render_mode == "human" and self._pages is not None:
            self._pages.write()
        return None


class ReturnBallEnv(_ServeEnv, gym.Env):
    """Episodic: one serve, one stroke (module docstring)."""

    def __init__(self, scenario: str | Scenario = "default", distribution: str | None = None,
                 action: str = "offset", max_position_offset: float = 0.1,
                 max_velocity_offset: float = 1.0, reward: str = "referee",
                 render_mode: str | None = None, html: str = "return_ball.html"):
        self._init_serve_env(reward, render_mode, html)
        _choice("action", action, ACTION_MODES)
        for name, value in (("max_position_offset", max_position_offset),
                            ("max_velocity_offset", max_velocity_offset)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, not {value}")
        self.scenario = make_scenario(scenario, distribution)
        self.action_mode = action
        if action == "offset":
            add_player = functools.partial(add_analytical_player, player_type=StrokeOffsetPlayer)
            size, low, high = 14, OBSERVATION_LOW, OBSERVATION_HIGH
        else:
            add_player = functools.partial(add_analytical_player, player_type=AbsoluteStrokePlayer)
            size, low, high = 15, ABSOLUTE_LOW, ABSOLUTE_HIGH
        self.serve_diagram = ServeDiagram(self.scenario, player=add_player,
                                          log_ball=self._logs_poses)
        self.player = self.serve_diagram.player
        self.scale = np.r_[np.full(7, float(max_position_offset)),
                           np.full(7, float(max_velocity_offset))]
        limits = self.player.limits if action == "absolute" else None
        if limits is not None:
            lower, upper = limits.lower + limits.margin, limits.upper - limits.margin
            self.q_centre, self.q_half = 0.5 * (upper + lower), 0.5 * (upper - lower)
            self.qd_max = limits.velocity
        self.action_space = gym.spaces.Box(-1.0, 1.0, (size,), dtype=np.float32)
        self.observation_space = gym.spaces.Box(low.astype(np.float32), high.astype(np.float32),
                                                dtype=np.float32)
        self._episode = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        serve_seed = _serve_seed(self, options)
        diagram = self.serve_diagram
        result = diagram.run(serve_seed)  # stops at the player's decision, or the episode's end
        context = self.player.GetMyContextFromRoot(diagram.context)
        now = context.get_time()
        if self.action_mode == "offset":
            state = self.player.player_state(context)
            committed, observation = bool(state.committed), np.zeros(10)
            if committed:
                s = state.stroke
                observation = np.r_[s.p_hit, s.v_hit, s.t_hit - now, s.spin]
        else:
            state = self.player.player_state(context)
            committed, observation = state.window is not None, np.zeros(18)
            if committed:
                window, (ball, _) = state.window, state.estimate
                plane = (np.zeros(7) if window.plane is None
                         else np.r_[window.plane[0], window.plane[1], window.plane[2] - now])
                observation = np.r_[ball, window.start - now, window.end - now, plane]
        low, high = self.observation_space.low, self.observation_space.high
        observation = np.clip(observation, low, high).astype(np.float32)
        t_end = result.predicted_crossing[6] + self.scenario.after_crossing
        self._episode = {"seed": serve_seed, "committed": committed, "t_end": t_end,
                         "observation": observation, "start": result}
        return observation.copy(), {"serve_seed": serve_seed, "committed": committed,
                                    "time": now}

    def stroke_of(self, action) -> tuple[np.ndarray, np.ndarray, float]:
        """The absolute mode's stroke for ``action`` (checked: :func:`checked_action`) at the
        current decision: theta_hit = centre + a[:7] * half range of the joint limits (less the
        planner's 0.05 rad margin), theta_dot_hit = a[7:14] * velocity limit, t_hit = start +
        (a[14] + 1) / 2 * (end - start) over the hittable window (absolute times, s)."""
        a = checked_action(action, 15)
        window = self.player.player_state(
            self.player.GetMyContextFromRoot(self.serve_diagram.context)).window
        t_hit = window.start + 0.5 * (a[14] + 1.0) * (window.end - window.start)
        return self.q_centre + a[:7] * self.q_half, a[7:14] * self.qd_max, t_hit

    def step(self, action):
        if self._episode is None:
            raise RuntimeError("call reset() before step()")
        size = self.action_space.shape[0]
        checked = checked_action(action, size)  # before the episode is used up
        episode, self._episode = self._episode, None
        diagram = self.serve_diagram
        if episode["committed"]:
            context = self.player.GetMyMutableContextFromRoot(diagram.context)
            if self.action_mode == "offset":
                a = checked * self.scale
                self.player.apply_offset(context, a[:7], a[7:])
            else:
                self.player.apply_stroke(context, *self.stroke_of(checked))
            diagram.advance(episode["t_end"])  # the referee may end it earlier
        outcome = diagram.referee.GetOutputPort("outcome").Eval(
            diagram.referee.GetMyContextFromRoot(diagram.context))
        reward, info = self._episode_end(outcome, episode["seed"], episode["start"])
        info["committed"] = episode["committed"]
        return episode["observation"].copy(), reward, True, False, info


def _setpoint_player(builder, world, controller, scenario: Scenario, rate: float) -> list:
    """Vision, the agent's set-point player and the observation vector, exported as the
    diagram's ``actions`` input and ``observations`` output."""
    seeded, estimator = add_perception(builder, world, scenario)
    player = builder.AddNamedSystem("setpoint_player",
                                    SetpointIncrementPlayer(rate, setpoint_lead=SETPOINT_LEAD,
                                                            offset=SERVO_PERIOD))
    builder.ExportInput(player.GetInputPort("increment"), "actions")
    add_servo_hold(builder, (player.GetOutputPort("desired_state"),
                             player.GetOutputPort("desired_acceleration")), controller)
    add_observations(builder, world, estimator)
    return seeded


def add_observations(builder, world, estimator) -> None:
    """The step environment's ``observations`` output (:class:`StepObservation`): the arm's
    measured state and the estimator's ball state and status."""
    observations = builder.AddNamedSystem("observations", StepObservation())
    builder.Connect(world.plant.get_state_output_port(world.robot),
                    observations.get_input_port(0))
    builder.Connect(estimator.GetOutputPort("state"), observations.get_input_port(1))
    builder.Connect(estimator.GetOutputPort("status"), observations.get_input_port(2))
    builder.ExportOutput(observations.get_output_port(), "observations")


def offset_player(builder, world, controller, scenario: Scenario, player: str,
                  rate: float) -> list:
    """The registered ``player`` drives the arm with the agent's offset added to its desired
    state (:class:`SetpointOffset` at ``rate``, exported as the ``actions`` input); the
    ``observations`` output as :func:`_setpoint_player`'s, from the player's own estimator if it
    has one (else one is added)."""
    offset = builder.AddNamedSystem("setpoint_offset", SetpointOffset(rate, offset=SERVO_PERIOD))
    total = builder.AddNamedSystem("desired_state_with_offset", Adder(2, 14))
    builder.Connect(offset.GetOutputPort("desired_state"), total.get_input_port(1))
    builder.Connect(total.get_output_port(), controller.get_input_port_desired_state())
    builder.ExportInput(offset.GetInputPort("increment"), "actions")
    ports = ControllerPorts(total.get_input_port(0),
                            controller.get_input_port_desired_acceleration())
    seeded = player_function(player)(builder, world, ports, scenario)
    # add_perception's systems, if the player has them.
    seen = [n for n in ("ball_flight_estimator", "ball_oracle") if builder.HasSubsystemNamed(n)]
    if seen:
        estimator = builder.GetSubsystemByName(seen[0])
    else:
        more, estimator = add_perception(builder, world, scenario)
        seeded = seeded + more
    add_observations(builder, world, estimator)
    return seeded


class _EpisodeSimulator:
    """The serve diagram's simulator as ``DrakeGymEnv`` uses it, except that ``AdvanceTo``
    advances as the serve episodes do (:meth:`ServeDiagram.advance`: the integrator's accuracy
    decided once per referee tick instead of by the monitor after every step)."""

    def __init__(self, serve_diagram: ServeDiagram):
        self._serve_diagram = serve_diagram

    def AdvanceTo(self, end: float):  # noqa: N802 (Drake's name)
        return self._serve_diagram.advance(end)

    def __getattr__(self, name):
        return getattr(self._serve_diagram.simulator, name)


class ReturnBallStepEnv(_ServeEnv, DrakeGymEnv):
    """Step-based: joint set-point increments at ``control_rate`` Hz (module docstring)."""

    def __init__(self, scenario: str | Scenario = "default", distribution: str | None = None,
                 control_rate: float = 100.0, reward: str = "referee",
                 render_mode: str | None = None, html: str = "return_ball_step.html",
                 player: str | None = None):
        self._init_serve_env(reward, render_mode, html)
        ratio = SERVO_RATE / float(control_rate)
        if not (math.isfinite(control_rate) and control_rate >= 50.0
                and abs(ratio - round(ratio)) < 1e-9):
            raise ValueError(f"control_rate must be >= 50 Hz and divide the {SERVO_RATE:g} Hz "
                             f"servo rate, not {control_rate}")
        self.scenario = make_scenario(scenario, distribution)
        if player is None:
            add_player = functools.partial(_setpoint_player, rate=float(control_rate))
        else:
            player_function(player)  # an unknown name: PlayerError naming the choices
            check_player(player, self.scenario)
            add_player = functools.partial(offset_player, player=player,
                                           rate=float(control_rate))
        self.serve_diagram = ServeDiagram(self.scenario, player=add_player,
                                          log_ball=self._logs_poses)
        self._initial = self.serve_diagram.context.Clone()
        metadata = {"render_modes": list(RENDER_MODES), "render_fps": float(control_rate)}
        self.metadata = dict(metadata)  # DrakeGymEnv changes it in place: not the class's
        super().__init__(simulator=self.serve_diagram.simulator, time_step=1.0 / control_rate,
                         action_space=gym.spaces.Box(-1.0, 1.0, (7,), dtype=np.float32),
                         observation_space=gym.spaces.Box(
                             StepObservation.low.astype(np.float32),
                             StepObservation.high.astype(np.float32), dtype=np.float32),
                         reward=lambda system, context: 0.0, action_port_id="actions",
                         observation_port_id="observations", reset_handler=self._start_serve,
                         render_mode=None)
        # DrakeGymEnv sets its own modes (they need a visualizer in the diagram): ours render
        # the serve diagram's state (_ServeEnv.render).
        self.metadata, self.render_mode = metadata, render_mode
        self.simulator = _EpisodeSimulator(self.serve_diagram)
        self._options = None
        self._serve_seed = None
        self._start = None
        self._t_end = np.inf

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._options = options
        observation, _ = super().reset(seed=seed)
        return np.asarray(observation, dtype=np.float32), {"serve_seed": self._serve_seed}

    def _start_serve(self, simulator, context, seed) -> None:
        """The serve episode's start, as ``ServeDiagram.run`` makes it
        (:func:`tt_drake.diagrams.station.reset_episode`), the loggers cleared."""
        diagram = self.serve_diagram
        serve_seed = self._serve_seed = _serve_seed(self, self._options)
        # The episode reset of every runner (a fresh integrator included: an error-controlled
        # integrator would otherwise start with the step size the previous episode ended with).
        serve = reset_episode(diagram.simulator, self._initial, self.scenario.world.simulator,
                              diagram.seeded, diagram.world, serve_seed)
        self._t_end = float(serve.crossing.t + self.scenario.after_crossing)
        for logger in (diagram.arm_logger, diagram.ball_logger):
            if logger is not None:
                logger.FindMutableLog(context).Clear()
        crossing = np.r_[serve.crossing.position, serve.crossing.velocity, serve.crossing.t]
        self._start = EpisodeResult(serve_seed, list(serve.launch_state), list(crossing), 0.0,
                                    None, 0.0)
        simulator.Initialize()

    def step(self, action):
        action = checked_action(action, 7)
        observation, _, terminated, truncated, _ = super().step(action)
        diagram = self.serve_diagram
        if not terminated and diagram.context.get_time() >= self._t_end - 1e-9:
            truncated = True
        reward, info = 0.0, {}
        if terminated or truncated:
            outcome = diagram.referee.GetOutputPort("outcome").Eval(
                diagram.referee.GetMyContextFromRoot(diagram.context))
            reward, info = self._episode_end(outcome, self._serve_seed, self._start)
        return np.asarray(observation, dtype=np.float32), reward, terminated, truncated, info
