"""Checking, before a long command's first stage, that every input file it will read is there.

A run that reads a missing file only in its last stage fails after all the others have run;
commands call :func:`check_inputs` first, and a missing or unreadable file is one line naming it.
"""

from tt_drake.diagrams.scenario import Scenario
from tt_drake.serves import load_real_states
from tt_drake.systems.world import model_path


def check_inputs(scenario: Scenario, distributions: tuple[str, ...] = ()) -> None:
    """The scenario's model files, and the real serve states if the scenario's distribution or
    one in ``distributions`` (others the command will switch to) is ``real``. Raises
    ``ModelFileError`` or ``ServeError``."""
    models = scenario.world.models
    for name in (models.table, models.ball) + ((models.robot,) if scenario.world.with_robot
                                               else ()):
        model_path(name)
    if "real" in (scenario.launcher.distribution, *distributions):
        load_real_states(scenario.launcher.real_serves or None)
