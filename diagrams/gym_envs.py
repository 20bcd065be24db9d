"""Gymnasium environments over the serve diagram (registered by :mod:`tt_drake.gym`).

Both are runners (DESIGN.md): they build the serve diagram of
:class:`tt_drake.diagrams.episodes.ServeDiagram` once, with a player that lets an agent act, and
run serve episodes on it. Options (keyword arguments of ``gymnasium.make``): ``scenario`` (a
name in models/, a YAML path or a :class:`Scenario`), ``distribution`` (overrides the launcher's
serve distribution: ``default``, ``real`` or ``fixed``). ``reset(seed=...)`` seeds the
environment's generator, which draws the serve's seed (camera noise included, as
``ServeDiagram.run``); ``reset(options={"serve_seed": k})`` replays serve ``k`` whatever the
generator says. The same seed gives the same observation, and the same actions the same reward.

``tt_drake/ReturnBall-v0`` (:class:`ReturnBallEnv`): episodic, one serve per episode and one
step per episode, in the black-box style of fancy_gym's table-tennis tasks. The analytical player
(the teacher) tracks the ball and plans its stroke; ``reset`` simulates until it commits to the
stroke (the planning tick at which the hitting stage has begun: it re-plans no more, paper
section III-A) and returns what it then knows. ``step(action)`` changes the stroke's end, plays
it and the rest of the episode, and returns the paper's reward; ``terminated`` is always True.

- observation (10): the predicted hitting point p_hit (m, world frame), the ball's velocity there
  v_hit (m/s), the time left until the hit t_hit - t (s), and the spin the planner predicts there
  omega_hit (rad/s; the estimator sees no spin, so today this is the spin the table bounce gives
  a ball served without spin; it carries an estimated spin once the planner gets one).
- action (14) in [-1, 1]: the offset to the analytical hitting configuration,
  theta_hit += a[:7] * max_position_offset (rad, default 0.1) and
  theta_dot_hit += a[7:] * max_velocity_offset (rad/s, default 1.0), clipped to the joint limits.
  An action of zeros plays the analytical player's stroke, bit for bit.
- reward: the referee's (:mod:`tt_drake.referee_rules`): 0 missed, 0.2 hit but not returned,
  0.3 + 0.7 exp(-d^2 / (2 sigma^2)) for a legal return landing d from the target, at most 0.1 if
  the robot touched the table.
- ``info["is_success"]``: the return landed on the opponent's half within ``target_radius``
  (0.2 m) of the target (fancy_gym's definition); ``info["outcome"]`` the referee's verdict.

If the player never commits (it found no stroke it could play), ``reset`` has already simulated
the whole episode: the observation is zeros, ``info["committed"]`` is False and ``step`` returns
the outcome without playing the action.

``tt_drake/ReturnBallStep-v0`` (:class:`ReturnBallStepEnv`): step-based, on Drake's
``pydrake.gym.DrakeGymEnv``. The agent moves the arm's joint set-points at ``control_rate`` Hz
(default 100) through :class:`tt_drake.systems.gym_players.SetpointIncrementPlayer`; the
InverseDynamicsController tracks them as it tracks the players'. A step's action takes effect one
servo tick (2 ms) into the step and lasts one control period.

- observation (22): the arm's state q (rad), q_dot (rad/s); the estimator's ball state p (m),
  v (m/s) (zeros until it tracks the ball), its status: tracking (0/1) and the time of the
  estimate (s, episode time).
- action (7) in [-1, 1]: set-point increments, a * (velocity limit / control_rate) rad per step.
- reward: 0 on every step but the last, which gets the paper's reward (as above); the episode
  terminates when the referee decides the outcome (the return landed, hit the net or fell; a
  missed ball at the floor) and is truncated at the predicted crossing of the hitting plane plus
  ``Scenario.after_crossing`` (the serve episode's end). ``info`` holds ``is_success`` and
  ``outcome`` on the last step.
"""

from __future__ import annotations

import dataclasses
import functools

import gymnasium as gym
import numpy as np
from pydrake.gym import DrakeGymEnv

from tt_drake.diagrams.episodes import (
    SETPOINT_LEAD,
    ServeDiagram,
    add_analytical_player,
    add_perception,
    episode_seed,
)
from tt_drake.diagrams.scenario import Scenario, load_scenario, validate
from tt_drake.referee_rules import Outcome
from tt_drake.systems.gym_players import (
    SetpointIncrementPlayer,
    StepObservation,
    StrokeOffsetPlayer,
)
from tt_drake.systems.wam import add_servo_hold
from tt_drake.systems.world import set_ball_state
from tt_drake.wam_params import SERVO_PERIOD

OBSERVATION_FIELDS = ("p_hit_x", "p_hit_y", "p_hit_z", "v_hit_x", "v_hit_y", "v_hit_z",
                      "time_to_hit", "spin_x", "spin_y", "spin_z")
#: Bounds of ReturnBall-v0's observation (time to hit from 0): observations are clipped to them.
OBSERVATION_HIGH = np.r_[np.full(3, 5.0), np.full(3, 50.0), 5.0, np.full(3, 1000.0)]
OBSERVATION_LOW = np.r_[-OBSERVATION_HIGH[:6], 0.0, -OBSERVATION_HIGH[7:]]
STEP_OBSERVATION_FIELDS = (tuple(f"q{i}" for i in range(1, 8))
                           + tuple(f"qd{i}" for i in range(1, 8))
                           + ("ball_x", "ball_y", "ball_z", "ball_vx", "ball_vy", "ball_vz",
                              "tracking", "estimate_time"))


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


def _serve_seed(env: gym.Env, options: dict | None) -> int:
    """The serve of this episode: ``options["serve_seed"]``, else drawn from ``env.np_random``."""
    if options and options.get("serve_seed") is not None:
        return int(options["serve_seed"])
    return int(env.np_random.integers(0, 2**32))


def _fresh_integrator(diagram: ServeDiagram) -> None:
    """A fresh integrator, as ``ServeDiagram.run`` makes one: an error-controlled integrator
    would otherwise start each episode with the step size the previous one ended with, and the
    same serve would replay only to ~1e-8 m (measured: a landing 3e-8 m apart), not bit for
    bit."""
    from pydrake.systems.analysis import ApplySimulatorConfig

    ApplySimulatorConfig(diagram.scenario.world.simulator, diagram.simulator)


def _no_rendering(render_mode) -> None:
    if render_mode is not None:
        raise ValueError(f"render_mode {render_mode!r} is not supported: record episodes with "
                         "tt-drake serve --html")


def _outcome_info(outcome: Outcome, serve_seed: int) -> dict:
    return {"is_success": bool(outcome.on_target), "outcome": outcome.as_dict(),
            "serve_seed": serve_seed}


class ReturnBallEnv(gym.Env):
    """Episodic: one serve, one stroke (module docstring)."""

    metadata = {"render_modes": []}

    def __init__(self, scenario: str | Scenario = "default", distribution: str | None = None,
                 max_position_offset: float = 0.1, max_velocity_offset: float = 1.0,
                 render_mode: str | None = None):
        _no_rendering(render_mode)
        if not (max_position_offset > 0 and max_velocity_offset > 0):
            raise ValueError("max_position_offset and max_velocity_offset must be > 0")
        self.scenario = make_scenario(scenario, distribution)
        add_player = functools.partial(add_analytical_player, player_type=StrokeOffsetPlayer)
        self.serve_diagram = ServeDiagram(self.scenario, player=add_player)
        self.player = self.serve_diagram.player
        self.scale = np.r_[np.full(7, float(max_position_offset)),
                           np.full(7, float(max_velocity_offset))]
        self.action_space = gym.spaces.Box(-1.0, 1.0, (14,), dtype=np.float64)
        self.observation_space = gym.spaces.Box(OBSERVATION_LOW, OBSERVATION_HIGH,
                                                dtype=np.float64)
        self._episode = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        serve_seed = _serve_seed(self, options)
        diagram = self.serve_diagram
        result = diagram.run(serve_seed)  # stops when the player commits, or at the episode's end
        context = self.player.GetMyContextFromRoot(diagram.context)
        state = self.player.player_state(context)
        observation = np.zeros(10)
        if state.committed:
            s = state.stroke
            observation = np.r_[s.p_hit, s.v_hit, s.t_hit - context.get_time(), s.spin]
            observation = np.clip(observation, OBSERVATION_LOW, OBSERVATION_HIGH)
        t_end = result.predicted_crossing[6] + self.scenario.after_crossing
        self._episode = {"seed": serve_seed, "committed": bool(state.committed), "t_end": t_end,
                         "observation": observation}
        return observation.copy(), {"serve_seed": serve_seed, "committed": state.committed,
                                    "time": context.get_time()}

    def step(self, action):
        if self._episode is None:
            raise RuntimeError("call reset() before step()")
        episode, self._episode = self._episode, None
        diagram = self.serve_diagram
        if episode["committed"]:
            a = np.clip(np.asarray(action, dtype=float).reshape(14), -1.0, 1.0) * self.scale
            self.player.apply_offset(self.player.GetMyMutableContextFromRoot(diagram.context),
                                     a[:7], a[7:])
            diagram.advance(episode["t_end"])  # the referee may end it earlier
        outcome = diagram.referee.GetOutputPort("outcome").Eval(
            diagram.referee.GetMyContextFromRoot(diagram.context))
        info = _outcome_info(outcome, episode["seed"]) | {"committed": episode["committed"]}
        return episode["observation"].copy(), float(outcome.reward), True, False, info


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
    observations = builder.AddNamedSystem("observations", StepObservation())
    builder.Connect(world.plant.get_state_output_port(world.robot),
                    observations.get_input_port(0))
    builder.Connect(estimator.GetOutputPort("state"), observations.get_input_port(1))
    builder.Connect(estimator.GetOutputPort("status"), observations.get_input_port(2))
    builder.ExportOutput(observations.get_output_port(), "observations")
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


class ReturnBallStepEnv(DrakeGymEnv):
    """Step-based: joint set-point increments at ``control_rate`` Hz (module docstring)."""

    metadata = {"render_modes": []}

    def __init__(self, scenario: str | Scenario = "default", distribution: str | None = None,
                 control_rate: float = 100.0, render_mode: str | None = None):
        _no_rendering(render_mode)
        from tt_drake.wam_params import SERVO_RATE

        ratio = SERVO_RATE / float(control_rate)
        if not (control_rate >= 50.0 and abs(ratio - round(ratio)) < 1e-9):
            raise ValueError(f"control_rate must be >= 50 Hz and divide the {SERVO_RATE:g} Hz "
                             f"servo rate, not {control_rate}")
        self.scenario = make_scenario(scenario, distribution)
        add_player = functools.partial(_setpoint_player, rate=float(control_rate))
        self.serve_diagram = ServeDiagram(self.scenario, player=add_player)
        self._initial = self.serve_diagram.context.Clone()
        self.metadata = {"render_modes": []}  # DrakeGymEnv adds modes to it; not to the class's
        super().__init__(simulator=self.serve_diagram.simulator, time_step=1.0 / control_rate,
                         action_space=gym.spaces.Box(-1.0, 1.0, (7,), dtype=np.float64),
                         observation_space=gym.spaces.Box(StepObservation.low,
                                                          StepObservation.high,
                                                          dtype=np.float64),
                         reward=lambda system, context: 0.0, action_port_id="actions",
                         observation_port_id="observations", reset_handler=self._start_serve,
                         render_mode=None)
        self.metadata = {"render_modes": []}  # those modes need a visualizer in the diagram
        self.simulator = _EpisodeSimulator(self.serve_diagram)
        self._options = None
        self._serve_seed = None
        self._t_end = np.inf

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._options = options
        observation, _ = super().reset(seed=seed)
        return np.array(observation), {"serve_seed": self._serve_seed}

    def _start_serve(self, simulator, context, seed) -> None:
        """The serve episode's start, as ``ServeDiagram.run`` makes it: the saved initial
        context, the seeds (the launcher gets the serve's, the others derived ones), the ball at
        its launch state."""
        diagram = self.serve_diagram
        serve_seed = self._serve_seed = _serve_seed(self, self._options)
        context.SetTimeStateAndParametersFrom(self._initial)
        for k, system in enumerate(diagram.seeded):
            system.set_seed(system.GetMyMutableContextFromRoot(context),
                            serve_seed if k == 0 else episode_seed(serve_seed, k))
        serve = diagram.launcher.serve(diagram.launcher.GetMyContextFromRoot(context))
        set_ball_state(diagram.world, diagram.world.plant.GetMyMutableContextFromRoot(context),
                       serve.launch_state)
        self._t_end = float(serve.crossing.t + self.scenario.after_crossing)
        _fresh_integrator(diagram)
        simulator.Initialize()

    def step(self, action):
        action = np.clip(np.asarray(action, dtype=float).reshape(7), -1.0, 1.0)
        observation, _, terminated, truncated, _ = super().step(action)
        diagram = self.serve_diagram
        if not terminated and diagram.context.get_time() >= self._t_end - 1e-9:
            truncated = True
        reward, info = 0.0, {}
        if terminated or truncated:
            outcome = diagram.referee.GetOutputPort("outcome").Eval(
                diagram.referee.GetMyContextFromRoot(diagram.context))
            reward, info = float(outcome.reward), _outcome_info(outcome, self._serve_seed)
        return np.array(observation), reward, terminated, truncated, info
