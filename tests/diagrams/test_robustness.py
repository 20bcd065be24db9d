"""Issue 18's defects, one test each: bad numbers never give a wrong answer, bad input is one line
and exit status 2, outputs survive a full disk, caches survive damage, run folders are locked.

Each test failed on the code before the fix (docs/robustness.md lists them with the fix)."""


import pytest

from tt_drake.diagrams.cli import main
from tt_drake.diagrams.scenario import ScenarioError, load_scenario


def one_line_error(capsys, argv, code=2):
    """Run ``tt-drake argv`` in this process; the exit status and the single stderr line."""
    try:
        status = main(argv)
    except SystemExit as exit_:
        status = exit_.code
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == code, err
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# -- 1. scenario values are checked at the boundary ----------------------------------------------

INVALID_FIELDS = {
    "referee_rate: .inf\n": "referee_rate must be finite",
    "referee: {target_radius: -0.2}\n": "referee.target_radius must be > 0",
    "launcher: {spin_max: .nan}\n": "launcher.spin_max must be finite",
    "world: {simulator: {max_step_size: .inf}}\n": "world.simulator.max_step_size must be finite",
    "world: {simulator: {accuracy: .nan}}\n": "world.simulator.accuracy must be finite",
    "world: {simulator: {integration_scheme: bogus}}\n":
        "world.simulator.integration_scheme 'bogus' is not one of",
    "world: {plant: {contact_model: bogus}}\n": "world.plant.contact_model 'bogus' is not one of",
    "aerodynamics: {drag_k: .nan}\n": "aerodynamics.drag_k must be finite",
    "aerodynamics: {drag_k: -0.1}\n": "aerodynamics.drag_k must be >= 0",
    "world: {simulator: {max_step_size: -0.002}}\n": "world.simulator.max_step_size must be > 0",
    "controller: {kp: [900, 900, 900, .nan, 900, 900, 900]}\n": "controller.kp [3] must be finite",
    "controller: {kd: [60, 60, 60, 60, 60, 60, -1]}\n": "controller.kd [6] must be >= 0",
    "after_crossing: .inf\n": "after_crossing must be finite",
}


@pytest.mark.parametrize("text, message", INVALID_FIELDS.items())
def test_invalid_scenario_values_are_refused_naming_the_field(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_scenario(str(path))


def test_every_invalid_field_is_named_in_one_line(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("referee_rate: .inf\nreferee: {target_radius: -0.2}\n")
    line = one_line_error(capsys, ["serve", "--scenario", str(path), "--serves", "1", "--quiet"])
    assert "referee_rate must be finite" in line and "referee.target_radius must be > 0" in line


def test_invalid_values_set_through_the_api_never_reach_drake():
    from tt_drake.diagrams.episodes import ServeDiagram

    scenario = load_scenario("default")
    scenario.referee_rate = float("inf")
    with pytest.raises(ScenarioError, match="referee_rate must be finite"):
        ServeDiagram(scenario, "idle")


def test_malformed_model_files_are_one_line(tmp_path, capsys):
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='wam'><link name='a'>")  # not well-formed XML
    wrong = tmp_path / "wrong.urdf"
    wrong.write_text("<robot name='x'><link name='a'/><joint name='j'/></robot>")  # no WAM
    for path, message in ((broken, "malformed model file"), (wrong, "cannot load model file")):
        scenario = tmp_path / f"{path.stem}.yaml"
        scenario.write_text(f"world: {{models: {{robot: {path}}}}}\n")
        line = one_line_error(capsys, ["serve", "--scenario", str(scenario), "--serves", "1",
                                       "--quiet"])
        assert message in line and path.name in line
