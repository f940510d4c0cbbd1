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


# -- n sections (SPEC §6) --------------------------------------------------------------------
import dataclasses  # noqa: E402

import numpy as np  # noqa: E402

from cdcr_gym.params import PRESETS, SectionParams  # noqa: E402


def test_single_section_keywords_build_the_same_robot_as_sections():
    assert RobotParams(length=0.5, n_disks=5) == RobotParams(
        sections=(SectionParams(length=0.5, n_disks=5),)
    )
    assert RobotParams.preset("paper") == RobotParams()
    p = dataclasses.replace(RobotParams(), n_disks=4)  # replace keeps working on one section
    assert p.n_disks == 4 and p.sections[0].n_disks == 4


def test_tdcr2_preset_numbers():
    p = RobotParams.preset("tdcr2")
    assert p.n_sections == 2 and p.n_cables == 6 and p.length == pytest.approx(0.4)
    assert p.cable_section == (0, 0, 0, 1, 1, 1)
    assert np.degrees(p.cable_angles[:3]) == pytest.approx([90.0, -30.0, 210.0])
    assert p.backbone_linear_density == pytest.approx(0.0115)
    assert p.bending_stiffness == pytest.approx(54e9 * math.pi * 0.0014**4 / 64)
    # the proximal section carries all six cables: twice the distal section's limit
    lim1, lim2 = p.section_bend_limits
    assert lim1 == pytest.approx(2 * lim2) and lim1 <= math.pi
    assert lim2 == pytest.approx(p.max_tension * 0.01 * 0.2 / p.bending_stiffness)
    assert set(PRESETS) == {"paper", "tdcr2", "ftdcr_v4"}


def test_bend_limit_is_the_largest_bend_over_the_tension_box():
    # brute force over the vertices of the box for an uneven 4-cable section
    s = SectionParams(length=0.3, n_disks=6, cable_radius=0.01, cable_angles=(0.0, 1.2, 2.9, 4.4))
    p = RobotParams(sections=(s,), max_tension=20.0)
    u = np.stack([np.cos(s.cable_angles), np.sin(s.cable_angles)], axis=-1)
    corners = np.array(np.meshgrid(*[[0.0, 1.0]] * 4)).reshape(4, -1).T
    best = np.max(np.linalg.norm(corners @ u, axis=1)) * 20.0 * 0.01 * 0.3 / p.bending_stiffness
    assert p.section_bend_limits[0] == pytest.approx(best, rel=1e-12)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"cable_angles": (0.0, 1.0)}, "cable_angles"),
        ({"cable_angles": (0.0, 0.1, 0.2)}, "cable_angles"),  # all in a half-plane
        ({"cable_angles": (0.0, 0.0, 3.0)}, "cable_angles"),
        ({"cable_angles": (0.0, np.nan, 3.0)}, "cable_angles"),
        ({"length": -1.0}, "length"),
        ({"n_disks": 0}, "n_disks"),
    ],
)
def test_bad_section_values_raise_value_error_naming_the_field(kwargs, name):
    with pytest.raises(ValueError, match=name):
        SectionParams(**kwargs)


def test_bad_robot_values_raise_value_error_naming_the_field():
    with pytest.raises(ValueError, match="sections"):
        RobotParams(sections=())
    with pytest.raises(ValueError, match="length"):
        RobotParams(sections=(SectionParams(), SectionParams()), length=1.0)
    with pytest.raises(ValueError, match="robot"):
        RobotParams.preset("tdcr3")
