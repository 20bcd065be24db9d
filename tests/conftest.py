"""Fixtures shared by the test folders."""

import pytest

from tt_drake.systems.world import model_path


@pytest.fixture(scope="module")
def long_table(tmp_path_factory):
    """The shipped table with its top's collision box 3.40 m long instead of 2.74 m: a table the
    arm on the shipped mount can reach (tests/diagrams/test_robot_table.py)."""
    sdf = model_path("table_world.sdf").read_text(encoding="utf-8")
    old = "<size>1.525 2.74 0.05</size>"
    assert sdf.count(old) == 1  # the table top's collision box
    path = tmp_path_factory.mktemp("table") / "long_table.sdf"
    path.write_text(sdf.replace(old, "<size>1.525 3.40 0.05</size>"), encoding="utf-8")
    return str(path)
