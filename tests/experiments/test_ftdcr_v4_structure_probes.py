"""The structural probes of the FTDCR v4 robot (experiments/ftdcr_v4_structure_probes.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cdcr_gym.calibration import read_csv
from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.drive import TendonDrive, solve_drive
from cdcr_gym.calibration.report import load_fitted
from cdcr_gym.calibration.simulate import drive_geometry
from cdcr_gym.model.tendons import solve_tendon_law
from experiments.ftdcr_v4_structure_probes import (
    DATA,
    FIT,
    Probe,
    section_compliance,
    solve_curvatures,
)


@pytest.fixture(scope="module")
def fitted():
    robot, _ = load_fitted(FIT)
    drive = TendonDrive.of(robot)
    rows = read_csv(DATA / "val.csv", robot=robot, drive=drive).subset(slice(0, 60))
    return robot, drive, rows


def test_isotropic_without_capstan_is_the_library_solve(fitted):
    robot, drive, rows = fitted
    values = {"base_compliance": 1.5e-5, "youngs_modulus": robot.youngs_modulus}
    geom = drive_geometry(robot, drive, [values])
    d = play(rows.displacements, 1e-4)
    ours = solve_curvatures(
        geom, d, section_compliance(float(geom.ei[0]), np.zeros(3), np.zeros(3))
    )
    np.testing.assert_allclose(ours, solve_drive(geom, d).curvature[0], rtol=1e-7, atol=1e-9)


def test_anisotropic_compliance_has_its_axes():
    ei, a, phi = 2.0e-3, 0.3, np.radians(25.0)
    c = section_compliance(ei, np.array([0.0, a]), np.array([1.0, phi]))
    np.testing.assert_allclose(c[:2, :2], np.eye(2) / ei, atol=1e-9)
    block = c[2:, 2:]
    axis = np.array([np.cos(phi), np.sin(phi)])
    normal = np.array([-np.sin(phi), np.cos(phi)])
    np.testing.assert_allclose(block @ axis, axis / ((1 + a) * ei))
    np.testing.assert_allclose(block @ normal, normal / ((1 - a) * ei))


def test_capstan_loss_bends_the_distal_section_less(fitted):
    robot, drive, _ = fitted
    geom = drive_geometry(robot, drive, [{}])
    comp = section_compliance(float(geom.ei[0]), np.zeros(3), np.zeros(3))
    d = np.zeros((3, 9))
    d[:, 6] = [0.004, 0.006, 0.008]  # a distal tendon pulled: every section bends
    bent = np.linalg.norm(solve_curvatures(geom, d, comp), axis=2)
    lossy = np.linalg.norm(solve_curvatures(geom, d, comp, mu=0.3), axis=2)
    assert np.all(bent > 1.0)
    # its tension is lost on the way through the two bent sections below the distal one
    assert np.all(lossy[:, 2] < 0.99 * bent[:, 2])


def test_unknown_term_is_refused(fitted):
    robot, drive, _ = fitted
    with pytest.raises(ValueError, match="term must be one of"):
        Probe("twisted", robot, drive, {})


def _values(robot) -> dict:
    """A frame at the origin and a drive without play: the probe's inputs reach the law as given."""
    return {
        "base_x": 0.0,
        "base_y": 0.0,
        "base_z": 0.0,
        "marker_offset": 0.0,
        "drive_backlash": 0.0,
        "base_compliance": 0.0,
    }


def test_softening_is_the_tanh_map_of_the_pulls(fitted):
    robot, drive, rows = fitted
    soft = Probe("softening", robot, drive, _values(robot))
    plain = Probe("isotropic", robot, drive, _values(robot))
    p = np.zeros(soft.size)
    p[-1] = 2.5  # d_s = 40 mm
    d = rows.displacements
    mapped = replace(rows, displacements=np.where(d > 0.0, 0.04 * np.tanh(d / 0.04), d))
    np.testing.assert_allclose(soft(rows, p), plain(mapped, p[:-1]), atol=1e-12)
    assert np.any(d > 0.003) and np.any(d < 0.0)  # both branches of the map are in the rows
    # d_s far beyond every command: the plain drive
    p[-1] = 1e-6
    np.testing.assert_allclose(soft(rows, p), plain(rows, p[:-1]), atol=1e-9)


def test_a_tension_cap_bends_the_robot_less(fitted):
    robot, drive, rows = fitted
    capped = Probe("tension_cap", robot, drive, _values(robot))
    plain = Probe("isotropic", robot, drive, _values(robot))
    p = np.zeros(capped.size)
    straight = plain(replace(rows, displacements=np.zeros_like(rows.displacements)), p[:-1])
    bend = np.linalg.norm(plain(rows, p[:-1]) - straight, axis=1)
    p[-1] = np.log(100.0 / Probe.CAP_START)  # far above every tension: no change
    np.testing.assert_allclose(capped(rows, p), plain(rows, p[:-1]), atol=1e-12)
    p[-1] = np.log(1.0 / Probe.CAP_START)  # 1 N
    capped_bend = np.linalg.norm(capped(rows, p) - straight, axis=1)
    # (a row may bend a little more: the cap also holds back a co-contracted antagonist)
    assert bend.max() > 0.1 and capped_bend.max() < 0.7 * bend.max()


def test_terms_combine_with_a_plus(fitted):
    robot, drive, _ = fitted
    both = Probe("anisotropic+softening", robot, drive, {})
    assert both.size == Probe("anisotropic", robot, drive, {}).size + 1
    assert both.start()[-1] == 1.0  # the softening's start, after the anisotropy's two
    with pytest.raises(ValueError, match="several joined by"):
        Probe("softening+softening", robot, drive, {})


def test_zero_new_terms_are_the_plain_model(fitted):
    """Every later term at its neutral value reproduces the isotropic probe."""
    robot, drive, rows = fitted
    plain = Probe("isotropic", robot, drive, _values(robot))
    base = plain(rows, np.zeros(plain.size))
    neutral = {
        "compliance_sections": np.zeros(3),
        "stiffening": np.zeros(1),
        "slack_tendons": np.zeros(9),
        "through_radius": np.zeros(1),
        "E_sections": np.zeros(2),
        "clearance": np.zeros(1),
    }
    for term, q in neutral.items():
        probe = Probe(term, robot, drive, _values(robot))
        p = np.concatenate([np.zeros(plain.size), q])
        np.testing.assert_allclose(probe(rows, p), base, atol=1e-9, err_msg=term)


def test_the_first_sections_give_is_the_base_compliance(fitted):
    """A give of section 1 under the load through it is the base compliance (every tendon runs
    through section 1); a give of section 3 alone changes only rows that load section 3."""
    robot, drive, rows = fitted
    with_base = Probe("isotropic", robot, drive, {**_values(robot), "base_compliance": 2e-5})
    sections = Probe("compliance_sections", robot, drive, _values(robot))
    p = np.zeros(sections.size)
    p[-3:] = [2.0, 0.0, 0.0]  # 2e-5 m/N in section 1
    np.testing.assert_allclose(
        sections(rows, p), with_base(rows, np.zeros(with_base.size)), atol=1e-9
    )
    p[-3:] = [0.0, 0.0, 2.0]
    d = np.zeros((2, 9))
    d[0, 0] = d[1, 6] = 0.006  # a base tendon, a distal tendon
    pulled = replace(rows.subset(slice(0, 2)), displacements=d)
    plain = Probe("isotropic", robot, drive, _values(robot))
    moved = np.linalg.norm(sections(pulled, p) - plain(pulled, np.zeros(plain.size)), axis=1)
    assert moved[1] > 1e-4 and moved[0] < 0.01 * moved[1]


def test_stiffening_bends_the_most_bent_section_less(fitted):
    """A rod that stiffens with its curvature holds its most bent section back (the others may
    bend more: the drives' tendons keep their lengths)."""
    robot, drive, rows = fitted
    geom = drive_geometry(robot, drive, [{}])
    comp = section_compliance(float(geom.ei[0]), np.zeros(3), np.zeros(3))
    d = play(rows.displacements, 0.0)
    plain = np.linalg.norm(solve_curvatures(geom, d, comp), axis=2).max(axis=1)
    stiff = np.linalg.norm(solve_curvatures(geom, d, comp, stiffening=5.0), axis=2).max(axis=1)
    bent = plain > 8.0  # 1/m
    assert bent.sum() > 5 and np.all(stiff[bent] < 0.98 * plain[bent])
    # small curvatures: almost the linear rod
    straightish = plain < 2.0
    np.testing.assert_allclose(stiff[straightish], plain[straightish], rtol=0.02)


def test_slack_offsets_shift_the_commands(fitted):
    robot, drive, rows = fitted
    slack = Probe("slack_tendons", robot, drive, _values(robot))
    plain = Probe("isotropic", robot, drive, _values(robot))
    offsets = np.linspace(-2.0, 2.0, 9)  # 1e-4 m
    p = np.concatenate([np.zeros(plain.size), offsets])
    shifted = replace(rows, displacements=rows.displacements - offsets * 1e-4)
    np.testing.assert_allclose(slack(rows, p), plain(shifted, p[: plain.size]), atol=1e-12)


def test_section_moduli_scale_the_section_compliance(fitted):
    robot, drive, rows = fitted
    geom = drive_geometry(robot, drive, [{}])
    comp = section_compliance(float(geom.ei[0]), np.zeros(3), np.zeros(3))
    d = play(rows.displacements, 0.0)
    # every section twice as stiff: E doubled
    stiff = solve_curvatures(geom, d, comp / 2.0)
    geom2 = drive_geometry(robot, drive, [{"youngs_modulus": 2 * robot.youngs_modulus}])
    np.testing.assert_allclose(stiff, solve_drive(geom2, d).curvature[0], rtol=1e-7, atol=1e-9)
    probe = Probe("E_sections", robot, drive, _values(robot))
    p = np.zeros(probe.size)
    p[-2:] = np.log(3.0)  # sections 2 and 3 three times as stiff as section 1
    plain = Probe("isotropic", robot, drive, _values(robot))
    assert not np.allclose(probe(rows, p), plain(rows, p[: plain.size]), atol=1e-4)


def test_clearance_is_a_consistent_equilibrium(fitted):
    """With pinhole play c every tendon's radius vector is moved by c towards the centre of
    curvature of each section it runs through, in its shortening and in its moment alike: the
    returned curvatures solve the linear drive law of that shifted geometry, and the pulled
    robot differs from the one without play."""
    robot, drive, rows = fitted
    geom = drive_geometry(robot, drive, [{}])
    comp = section_compliance(float(geom.ei[0]), np.zeros(3), np.zeros(3))
    d = play(rows.displacements, 0.0)
    c = 1e-4  # m
    u = solve_curvatures(geom, d, comp, clearance=c)  # (M, S, 2)
    g, lam = geom.coupling()
    g, lam = g[0], lam[0]
    norm = np.linalg.norm(u, axis=2, keepdims=True)
    towards = np.divide(u, norm, out=np.zeros_like(u), where=norm > 1e-9)
    runs = (np.asarray(geom.section_of)[:, None] >= np.arange(3)[None, :]).astype(float)
    gc = g[None] + (c * runs[None, :, :, None] * towards[:, None]).reshape(len(d), 9, 6)
    m = np.einsum("mcp,pq,mkq->mck", gc * lam[None, None], comp, gc)
    t, _ = solve_tendon_law(
        m,
        d,
        geom.stiffness[0],
        np.maximum(geom.pretension[0], 0.0),
        base_compliance=float(geom.base_compliance[0]),
    )
    again = np.einsum("pq,mkq,mk->mp", comp, gc, t).reshape(u.shape)
    np.testing.assert_allclose(again, u, rtol=1e-8, atol=1e-8)
    plain = solve_curvatures(geom, d, comp)
    assert np.max(np.abs(plain - u)) > 0.05  # 1/m: the play matters at 0.1 mm
