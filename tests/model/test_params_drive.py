"""RobotParams: the tendon drive (SPEC §8), the ftdcr_v4 preset, the params YAML."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import PRESETS, RobotParams
from cdcr_gym.model.tendons import solve_displacement_statics

DATA = Path(__file__).resolve().parents[2] / "data" / "real" / "ftdcr_v4"


# -- the drive fields ------------------------------------------------------------------------------
def test_drive_defaults_and_per_cable_views():
    p = RobotParams()
    assert p.tendon_stiffness == 2.0e4 and p.tendon_pretension == 2.0
    assert p.displacement_range == (-0.045, 0.045)
    assert p.cable_stiffness == (2.0e4,) * 3 and p.cable_pretension == (2.0,) * 3
    per = RobotParams(tendon_stiffness=[1e3, 2e3, 3e3], tendon_pretension=np.array([1, 2, 3]))
    assert per.tendon_stiffness == (1e3, 2e3, 3e3) and per.cable_pretension == (1.0, 2.0, 3.0)
    assert RobotParams(tendon_stiffness=math.inf).cable_stiffness == (math.inf,) * 3


@pytest.mark.parametrize(
    "field, value",
    [
        ("tendon_stiffness", 0.0),
        ("tendon_stiffness", -1e3),
        ("tendon_stiffness", float("nan")),
        ("tendon_stiffness", "stiff"),
        ("tendon_stiffness", (1e3, 1e3)),
        ("tendon_stiffness", (1e3, -1.0, 1e3)),
        ("tendon_pretension", -0.1),
        ("tendon_pretension", float("inf")),
        ("tendon_pretension", (1.0, 1.0, 1.0, 1.0)),
        ("displacement_range", (0.01, -0.01)),
        ("displacement_range", (0.0, 0.0)),
        ("displacement_range", (-0.01,)),
        ("displacement_range", 0.01),
        ("displacement_range", (-0.01, float("nan"))),
    ],
)
def test_drive_fields_are_validated(field, value):
    with pytest.raises(ValueError, match=field) as err:
        RobotParams(**{field: value})
    assert "RobotParams" in str(err.value)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_displacement_range_reaches_max_tension_and_releases(name):
    """Pulling one tendon to d_max with the others held at 0 saturates it; d_min slackens it."""
    p = RobotParams.preset(name)
    model = PCCModel(p)
    low, high = p.displacement_range
    pulls = np.eye(p.n_cables) * high
    releases = np.eye(p.n_cables) * low
    k, t0 = p.cable_stiffness, p.cable_pretension
    assert np.all(np.diag(solve_displacement_statics(model, pulls, k, t0).saturated))
    assert np.all(np.diag(solve_displacement_statics(model, releases, k, t0).slack))


# -- the real robot ----------------------------------------------------------------------------------
def test_ftdcr_v4_preset_matches_the_nominal_json():
    nominal = json.loads((DATA / "robot_nominal.json").read_text())
    p = RobotParams.preset("ftdcr_v4")
    n = nominal["num_segments"]
    assert p.n_sections == n == 3 and p.n_cables == 9
    lengths = [nominal["segment_lengths"][str(j + 1)] for j in range(n)]
    assert p.section_lengths == pytest.approx(lengths, abs=0, rel=1e-15)
    assert [s.n_disks for s in p.sections] == [
        nominal["links_per_segment"][str(j + 1)] for j in range(n)
    ]
    material = nominal["material_properties"]
    assert p.backbone_diameter == pytest.approx(2 * material["outer_radius"], rel=1e-15)
    assert p.youngs_modulus == material["youngs_modulus"]
    assert p.backbone_density == material["density"]
    assert p.disk_radius == nominal["radius"]
    segments = nominal["actuation_details"]["segments"]
    for j, section in enumerate(p.sections):
        assert section.cable_radius == segments[j]["distance_to_backbone"]
        count = segments[j]["number_of_tendons"]
        want = [
            nominal["seg_offsets"][j]
            + k * 2 * math.pi / count
            + nominal["tendon_angle_deltas"][j][k]
            for k in range(count)
        ]
        assert section.cable_angles == pytest.approx(want, abs=1e-15)
    drive = nominal["actuator_properties"]
    assert drive["tendon_kp_scale_factor"] == 1.0  # inverse-length scaling changes nothing
    assert p.cable_stiffness == (float(drive["tendon_kp"]),) * 9
    assert p.cable_pretension == tuple(drive["tendon_pretension"])
    # the bend limit holds (the reason max_tension is 9 N) and 10 N would break it
    assert max(p.section_bend_limits) <= math.pi
    with pytest.raises(ValueError, match="180"):
        replace(p, max_tension=10.0)


def test_ftdcr_v4_displacement_range_covers_the_recorded_commands():
    low, high = RobotParams.preset("ftdcr_v4").displacement_range
    for name in ("train.csv", "val.csv", "tendon_pull.csv"):
        lines = (DATA / name).read_text().splitlines()
        header = lines[0].split(",")
        cols = [i for i, h in enumerate(header) if h.startswith("servo_")]
        values = np.array([[float(r.split(",")[i]) for i in cols] for r in lines[1:]]) * 1e-3
        assert len(cols) == 9
        step = 1.534e-5  # the servos' quantisation step (m): "released" reads -10.0016 mm
        assert low - step <= values.min() and values.max() <= high, name
    assert low == pytest.approx(-0.010)  # "released" in the recordings


@pytest.mark.parametrize("task", ["Reach", "Track", "Pose", "Obstacle"])
def test_every_task_constructs_on_ftdcr_v4(task):
    env = gym.make(f"cdcr_gym/CCKA{task}-v0", robot="ftdcr_v4")
    try:
        env.reset(seed=0)
        assert env.action_space.shape == (9,)
        env.step(env.action_space.sample())
    finally:
        env.close()


def test_data_folder_is_a_complete_copy():
    names = {p.name for p in DATA.iterdir()}
    assert {
        "LICENSE",
        "SOURCE.md",
        "robot_nominal.json",
        "robot_calibrated_by_authors.json",
    } <= names
    assert {"train.csv", "val.csv", "tendon_pull.csv"} <= names
    assert "MIT" in (DATA / "LICENSE").read_text()


# -- YAML ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "params",
    [
        *PRESETS.values(),
        RobotParams(tendon_stiffness=math.inf, tendon_pretension=(0.0, 1.5, 3.25)),
        RobotParams(tendon_stiffness=(1e3, 2e3, 3.5e3), displacement_range=(-1e-3, 2e-3)),
    ],
)
def test_drive_round_trips_through_yaml(params):
    text = params.to_yaml()
    assert "tendon_stiffness" in text and "displacement_range" in text
    assert RobotParams.from_yaml(text) == params


def test_yaml_duplicate_key_is_refused_naming_it():
    text = "max_tension: 40.0\nyoungs_modulus: 3.0e10\nmax_tension: 60.0\n"
    with pytest.raises(ValueError, match="max_tension"):
        RobotParams.from_yaml(text)
    nested = "robot:\n  sections:\n  - length: 0.3\n    length: 0.4\n    n_disks: 3\n"
    with pytest.raises(ValueError, match="duplicate key 'length'"):
        RobotParams.from_yaml(nested)


@pytest.mark.parametrize(
    "text, name",
    [
        ("robot: [1, 2]\n", "params.robot"),
        ("robot: paper\n", "params.robot"),
        ("robot:\n  max_tension: 5.0\nbackend: [1]\n", "params.backend"),
        ("robot:\n  max_tension: 5.0\ncalibration: done\n", "params.calibration"),
        ("sections: abc\n", "params.sections"),
        ("sections:\n- [0.3, 3]\n", r"params.sections\[0\]"),
        ("- 1\n- 2\n", "params must be a mapping"),
    ],
)
def test_yaml_section_of_wrong_type_is_refused_naming_it(text, name):
    with pytest.raises(ValueError, match=name):
        RobotParams.from_yaml(text)


def test_params_does_not_import_params_yaml():
    """The dependency is one way: params_yaml imports params, never the reverse."""
    code = (
        "import sys; import cdcr_gym.model.params as p; "
        "p.RobotParams.from_yaml(p.RobotParams().to_yaml()); "
        "print('cdcr_gym.model.params_yaml' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    from cdcr_gym.model import params_yaml

    p = RobotParams.preset("tdcr2")
    assert params_yaml.from_yaml(params_yaml.to_yaml(p)) == p
