"""The stiffness-by-family diagnosis of the FTDCR v4 files
(experiments/ftdcr_v4_stiffness_by_family.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cdcr_gym.calibration import read_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.report import load_fitted
from experiments.ftdcr_v4_stiffness_by_family import apparent_modulus, family
from experiments.ftdcr_v4_structure_probes import DATA, FIT, Probe


def test_family_strips_repetition_direction_and_tags():
    assert family("rep1_pair12_same_dir60_hold") == "pair12_same"
    assert family("rep2_all3_scurve_dir0") == "all3_scurve"
    assert family("rep1_tendon4_id2_pull") == "tendon4"
    assert family("rep1_seg2_circle") == "seg2"
    assert family("rep1_seg3") == "seg3"


def test_apparent_modulus_recovers_a_known_stiffness():
    robot, _ = load_fitted(FIT)
    drive = TendonDrive.of(robot)
    rows = read_csv(DATA / "val.csv", robot=robot, drive=drive).subset(slice(0, 40))
    values = {"base_compliance": 1.5e-5, "drive_backlash": 1e-4, "marker_offset": 0.004}
    values.update({k: 0.0 for k in ("base_x", "base_y", "base_z")})
    probe = Probe("isotropic", robot, drive, values)
    p = np.zeros(probe.size)
    p[7] = np.log(1.4)
    # tips of the robot with E × 1.4, shifted by a constant offset (the alignment removes it)
    synthetic = replace(rows, tip=probe(rows, p) + np.array([0.002, -0.001, 0.003]))
    e_star, before, after = apparent_modulus(probe, synthetic)
    assert abs(e_star / (1.4 * robot.youngs_modulus) - 1.0) < 0.01
    assert before > 1.0 and after < 0.01  # mm
