"""The committed model files are the generator's output, so they agree with tt_drake.constants."""

from pathlib import Path

import pytest

from tt_drake.modelgen.__main__ import MODELS_DIR, generated_files


@pytest.mark.parametrize("name", sorted(generated_files()))
def test_committed_model_file_is_up_to_date(name):
    committed = Path(MODELS_DIR, name).read_text()
    assert committed == generated_files()[name](), (
        f"models/{name} is stale: run `tt-drake models` (python -m tt_drake.modelgen)")


def test_every_collision_geometry_has_contact_properties():
    for name, make in generated_files().items():
        text = make()
        n_collisions = text.count("<collision ")
        assert n_collisions > 0
        for prop in ("point_contact_stiffness", "hunt_crossley_dissipation", "mu_dynamic"):
            assert text.count(f"<drake:{prop}") == n_collisions, (name, prop)
