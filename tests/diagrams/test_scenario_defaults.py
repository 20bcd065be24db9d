"""The scenario dataclasses' defaults are models/default.yaml's values: one default per value,
whether a scenario is built in Python (``Scenario()``) or loaded from the default file."""

from pydrake.common.yaml import yaml_load_data

from tt_drake.diagrams.scenario import Scenario, dump_scenario, load_scenario, scenario_path


def _leaves(data, prefix=""):
    """Every (dotted path, value) of nested mappings."""
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _leaves(value, f"{prefix}{key}.")
    else:
        yield prefix[:-1], data


def test_every_value_the_default_file_names_is_the_dataclass_default():
    with open(scenario_path("default"), encoding="utf-8") as f:
        named = dict(_leaves(yaml_load_data(f)))
    defaults = dict(_leaves(yaml_load_data(dump_scenario(Scenario()))))
    assert "world.flight_accuracy" in named and "world.simulator.accuracy" in named
    assert {path: defaults[path] for path in named} == named


def test_the_loaded_default_scenario_is_the_dataclass_default():
    assert dump_scenario(load_scenario("default")) == dump_scenario(Scenario())
    assert Scenario().world.flight_accuracy == 1e-3
