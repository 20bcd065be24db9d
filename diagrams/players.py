"""The players, registered in one place: a name, the function that adds the player to a diagram
and (for players that read artefact files) the check run before anything is simulated.

A player function ``add(builder, world, controller, scenario) -> list`` adds the player's
systems to ``builder``; it reads the ball's state from
``world.plant.get_state_output_port(world.ball)`` (its own arm's from ``world.robot``), drives
``controller.get_input_port_desired_state()`` and ``get_input_port_desired_acceleration()``, and
returns the systems that draw random numbers (each has ``set_seed(context, seed)``; the episode
gives each its own seed derived from the episode's). The same function builds the player of a
serve, of each side of a rally (in that robot's frame) and of the Gymnasium step environment's
``player`` option; ``world`` and ``controller`` are then the station's ports
(:class:`WorldPorts`, :class:`ControllerPorts`, :func:`tt_drake.diagrams.station.station_ports`).

The runners find what they need by protocol, not by name: the player's system is the one with
a ``stroke`` output (the serve episode summarises it); in a rally every system with a
``play_again`` attribute has it set (it plays again after each stroke), and every ``planner``
attribute whose ``config`` has a ``target_x`` aims at the rally's target.

Registering: ``register_player(name, add)`` with a function, or with a ``"module:function"``
reference imported at the first use (the built-in players: their modules import pydrake, which
the ``tt-drake`` command's parser does not need). This module imports nothing of Drake.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass

from tt_drake.errors import BadInputError


class PlayerError(ValueError, BadInputError):
    """An unknown player name or a player that cannot be built."""


def drive_controller(builder, world, controller, system) -> None:
    """Wire a player ``system`` as the player functions above describe: its ``ball_state``
    input from the plant (and its ``arm_state``, if it has one, from its own arm), its
    ``desired_state`` and ``desired_acceleration`` outputs into ``controller``."""
    plant = world.plant
    builder.Connect(plant.get_state_output_port(world.ball), system.GetInputPort("ball_state"))
    if system.HasInputPort("arm_state"):
        builder.Connect(plant.get_state_output_port(world.robot),
                        system.GetInputPort("arm_state"))
    builder.Connect(system.GetOutputPort("desired_state"),
                    controller.get_input_port_desired_state())
    builder.Connect(system.GetOutputPort("desired_acceleration"),
                    controller.get_input_port_desired_acceleration())


@dataclass(frozen=True)
class RegisteredPlayer:
    """A player's name, its function (or a ``"module:function"`` reference to it) and the
    function ``check(scenario)`` that raises PlayerError before any simulation if the player
    cannot play ``scenario`` (its artefact files), or None."""

    name: str
    add: Callable | str
    check: Callable | str | None = None
    #: The player plays the learned artefacts of ``scenario.learned`` (the shipped sets apply).
    learned: bool = False


_REGISTRY: dict[str, RegisteredPlayer] = {}


class WorldPorts:
    """What a player function reads from the world, as ports: ``world.plant``'s state output
    port of ``world.ball`` (the ball's state, 13, in the player's robot's frame) and of
    ``world.robot`` (its arm's measured state, 14), and its arm's accelerations
    (``get_generalized_acceleration_output_port(world.robot)``, 7)."""

    class Plant:
        """The ``MultibodyPlant`` methods a player function calls, on the given ports."""

        def __init__(self, states: dict, accelerations: dict):
            self.states, self.accelerations = states, accelerations

        def get_state_output_port(self, instance):  # noqa: D102 (MultibodyPlant's name)
            return self.states[instance]

        def get_generalized_acceleration_output_port(self, instance):  # noqa: D102
            return self.accelerations[instance]

    def __init__(self, ball_port, arm_port=None, acceleration_port=None):
        self.ball = "ball"
        self.robot = None if arm_port is None else "robot"
        states = {self.ball: ball_port}
        if arm_port is not None:
            states[self.robot] = arm_port
        self.plant = self.Plant(states, {self.robot: acceleration_port})


class ControllerPorts:
    """What a player function reads from the controller, when its desired values go elsewhere
    first (a rally side's sub-diagram, the step environment's offset): the two input ports it
    should drive."""

    def __init__(self, state_port, acceleration_port):
        self.state_port, self.acceleration_port = state_port, acceleration_port

    def get_input_port_desired_state(self):  # noqa: D102 (InverseDynamicsController's name)
        return self.state_port

    def get_input_port_desired_acceleration(self):  # noqa: D102
        return self.acceleration_port


def register_player(name: str, add: Callable | str, check: Callable | str | None = None,
                    learned: bool = False) -> None:
    """Register (or replace) the player ``name``: ``add`` builds it (module docstring),
    ``check`` checks a scenario for it."""
    if not isinstance(name, str) or not name or name != name.strip():
        raise PlayerError(f"a player's name must be a non-empty word, not {name!r}")
    _REGISTRY[name] = RegisteredPlayer(name, add, check, learned)


def unregister_player(name: str) -> None:
    """Remove the player ``name`` from the registry (PlayerError if it is not registered)."""
    registered_player(name)
    del _REGISTRY[name]


def player_names() -> tuple[str, ...]:
    """The registered players' names, in the order they were registered."""
    return tuple(_REGISTRY)


def registered_player(name: str) -> RegisteredPlayer:
    """The registration of ``name``; PlayerError naming the choices if there is none."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise PlayerError(f"unknown player {name!r}; choose one of "
                          f"{', '.join(_REGISTRY)}") from None


def resolve(reference: Callable | str) -> Callable:
    """A function, or the one a ``"module:function"`` reference names (imported now)."""
    if callable(reference):
        return reference
    module, _, attribute = reference.partition(":")
    return getattr(importlib.import_module(module), attribute)


def player_function(player: str | Callable) -> Callable:
    """The function that adds ``player`` to a diagram: a registered name's, or ``player`` itself
    if it is a player function."""
    if callable(player):
        return player
    return resolve(registered_player(player).add)


def player_system(builder):
    """The player's system among ``builder``'s (a ``DiagramBuilder``): the one with a ``stroke``
    output, the last added if several (None if no system has one)."""
    found = None
    for system in builder.GetSystems():
        if system.HasOutputPort("stroke"):
            found = system
    return found


def check_player(player: str | Callable, scenario) -> None:
    """Raise PlayerError (one line) if ``player`` cannot play ``scenario``: an unknown name, or
    its check's verdict; a plain player function is not checked."""
    if callable(player):
        return
    check = registered_player(player).check
    if check is not None:
        resolve(check)(scenario)


def plays_learned_artefacts(player: str | Callable) -> bool:
    """Whether ``player`` (a registered name) plays the learned artefacts of
    ``scenario.learned``."""
    return isinstance(player, str) and registered_player(player).learned


EPISODES = "tt_drake.diagrams.episodes"
register_player("idle", f"{EPISODES}:add_idle_player")
register_player("analytical", f"{EPISODES}:add_analytical_player")
register_player("momp", f"{EPISODES}:add_momp_player", f"{EPISODES}:check_momp_artefacts",
                learned=True)
register_player("crkr", f"{EPISODES}:add_crkr_player", f"{EPISODES}:check_crkr_artefacts",
                learned=True)
