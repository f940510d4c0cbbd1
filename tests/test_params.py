"""RobotParams: defaults, derived quantities, validation."""

from __future__ import annotations

import math
from dataclasses import FrozenInstanceError

import pytest

from cdcr_gym.params import RobotParams


def test_defaults_are_the_papers_table_1_with_e_in_gpa():
    p = RobotParams()
    assert (p.length, p.backbone_diameter, p.cable_radius) == (0.641, 0.005, 0.029)
    assert p.youngs_modulus == 35e9
    assert p.n_disks == 9
    assert p.max_tension == 80.0


def test_derived_quantities():
    p = RobotParams()
    assert p.second_moment_of_area == pytest.approx(math.pi * 0.005**4 / 64)
    assert p.bending_stiffness == pytest.approx(35e9 * 3.0679615757712825e-11)
    # 80 N on one cable bends the elastica by about 79 degrees (the reason E is 35 GPa).
    assert math.degrees(p.max_bending_angle) == pytest.approx(79.35, abs=0.01)
    assert p.disk_spacing == pytest.approx(0.641 / 9)


def test_frozen():
    with pytest.raises(FrozenInstanceError):
        RobotParams().length = 1.0  # type: ignore[misc]


@pytest.mark.parametrize(
    "field, value",
    [
        ("length", 0.0),
        ("length", -0.641),
        ("length", float("nan")),
        ("backbone_diameter", 0.0),
        ("cable_radius", -0.029),
        ("youngs_modulus", 0.0),
        ("youngs_modulus", float("inf")),
        ("max_tension", 0.0),
        ("max_tension", -1.0),
        ("n_disks", 0),
        ("n_disks", 2.5),
        ("disk_mass", 0.0),
        ("backbone_density", "heavy"),
    ],
)
def test_bad_values_raise_value_error_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        RobotParams(**{field: value})


def test_disk_must_be_larger_than_cable_radius():
    with pytest.raises(ValueError, match="disk_radius"):
        RobotParams(disk_radius=0.02)
