"""Minimal tensions with coupled tendon moments, the reachable scale, the one-section API."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from tolerances import close

from cdcr_gym.model import statics as S
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams, SectionParams
from cdcr_gym.params import CABLE_ANGLES

pytestmark = pytest.mark.filterwarnings("error")

DEG = math.pi / 180.0
PAPER = RobotParams()
#: The legacy one-section model's outputs on fixed inputs (tests/data/write_legacy_arrays.py).
OLD = np.load(Path(__file__).parents[1] / "data" / "legacy_statics.npz")
TDCR2 = RobotParams.preset("tdcr2")
FOUR = SectionParams(
    length=0.15,
    n_disks=5,
    cable_radius=0.012,
    cable_angles=(10 * DEG, 95 * DEG, 200 * DEG, 280 * DEG),
)
UNEVEN = SectionParams(
    length=0.12, n_disks=4, cable_radius=0.008, cable_angles=(0.0, 100 * DEG, 230 * DEG)
)
MIXED = RobotParams(
    sections=(FOUR, UNEVEN, SectionParams(length=0.1, n_disks=3, cable_radius=0.005)),
    backbone_diameter=0.002,
    youngs_modulus=60e9,
    max_tension=5.0,
    disk_radius=0.02,
)
UNEVEN1 = RobotParams(
    sections=(UNEVEN,),
    backbone_diameter=0.002,
    youngs_modulus=60e9,
    max_tension=5.0,
    disk_radius=0.02,
)


def _paper_arcs(n, seed):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, 1.6, n)
    theta[:2] = 0.0
    return theta, rng.uniform(-np.pi, np.pi, n)


@pytest.mark.parametrize("pretension", [0.0, 5.0])
def test_paper_tension_ik_equals_todays(pretension):
    theta, phi = _paper_arcs(2000, 0)
    assert close(theta, OLD["tension_ik_theta"]) and close(phi, OLD["tension_ik_phi"])
    old_t = OLD[f"tensions_from_arc_{pretension:g}"]
    old_c = OLD[f"clipped_{pretension:g}"]
    new_t, new_c = S.tensions_from_arc(theta, phi, PAPER, pretension=pretension)
    assert np.max(np.abs(new_t - old_t)) <= 1e-12
    assert np.array_equal(new_c, old_c) and old_c.any() and not old_c.all()
    model = PCCModel(PAPER)
    w = np.stack([theta * np.cos(phi), theta * np.sin(phi)], axis=-1)[:, None, :]
    t, c = S.minimal_tensions(model, w, pretension)
    assert np.max(np.abs(t - old_t)) <= 1e-12 and np.array_equal(c, old_c)


def test_paper_reachable_scale_limit_and_arc_from_tensions_equal_todays():
    theta, phi = _paper_arcs(2000, 1)
    assert close(theta, OLD["scale_theta"]) and close(phi, OLD["scale_phi"])
    w = np.stack([theta * np.cos(phi), theta * np.sin(phi)], axis=-1)
    new = S.reachable_scale(PCCModel(PAPER), w[:, None, :])
    assert np.max(np.abs(new - OLD["workspace_scale"])) <= 1e-12 and np.any(new < 1.0)
    for p in (0.0, 3.0):
        assert np.max(np.abs(S.bending_limit(phi, PAPER, p) - OLD[f"bending_limit_{p:g}"])) <= 1e-12
    tensions = np.random.default_rng(2).uniform(0, 80, (500, 3))
    assert close(tensions, OLD["arc_tensions"])
    for i, a in enumerate(S.arc_from_tensions(tensions, PAPER)):
        b = OLD[f"arc_from_tensions_{i}"]
        assert np.max(np.abs(np.exp(1j * a) - np.exp(1j * b))) <= 1e-12 or np.allclose(a, b)
    assert np.allclose(
        S.arc_from_tensions(tensions, PAPER)[0], OLD["arc_from_tensions_0"], rtol=0, atol=1e-12
    )
    assert np.allclose(S.CABLE_DIRECTIONS, OLD["cable_directions"], atol=1e-15)


def _brute_minimal(vectors, moment):
    """Minimal-sum non-negative tensions over every pair and single cable (independent LP)."""
    best, best_t = np.inf, None
    n = len(vectors)
    for a, b in itertools.combinations(range(n), 2):
        mat = np.stack([vectors[a], vectors[b]], axis=1)
        if abs(np.linalg.det(mat)) < 1e-15:
            continue
        coef = np.linalg.solve(mat, moment)
        if np.all(coef >= -1e-12) and coef.sum() < best:
            best, best_t = coef.sum(), (a, b, coef)
    t = np.zeros(n)
    t[best_t[0]], t[best_t[1]] = best_t[2]
    return t


@pytest.mark.parametrize("params", [TDCR2, MIXED, UNEVEN1], ids=["tdcr2", "mixed", "uneven1"])
def test_round_trip_minimality_and_coupled_moments(params):
    model = PCCModel(params)
    box = np.random.default_rng(3).uniform(0, params.max_tension, (200, params.n_cables))
    w = model.bending_from_tensions(box)
    tensions, clipped = S.minimal_tensions(model, w)
    three = np.array([np.sum(model.cable_section == j) == 3 for j in model.cable_section])
    if three.all():
        assert not clipped.any()
    else:
        # a section of 4 cables: the minimal-sum (two-cable) tensions of a shape made with all
        # four can exceed the limit (documented: the min-sum reachable set is a subset)
        assert clipped.any() and not clipped.all()
    ok = ~clipped
    assert np.allclose(model.bending_from_tensions(tensions[ok]), w[ok], rtol=0, atol=1e-13)
    assert np.all(tensions >= 0.0) and np.all(tensions <= params.max_tension)
    # an independent section-by-section computation: own cables supply EI (κ_j − κ_{j+1})
    ei = params.bending_stiffness
    for n in range(0, 200, 20):
        for j in range(params.n_sections):
            kappa = w[n, j] / params.section_lengths[j]
            kappa_next = (
                w[n, j + 1] / params.section_lengths[j + 1] if j + 1 < params.n_sections else 0.0
            )
            own = model.cable_section == j
            expected = _brute_minimal(model.cable_vectors[own], ei * (kappa - kappa_next))
            raw = S.minimal_tensions(model, w[n] * S.reachable_scale(model, w[n]))[0]
            expected = expected * S.reachable_scale(model, w[n])
            assert np.allclose(raw[own], expected, rtol=1e-10, atol=1e-10)
    # with three cables per section the minimal tensions are componentwise below any other
    assert np.all(tensions[:, three] <= box[:, three] + 1e-9)


def test_clipping_is_reported_and_scale_brings_shapes_to_the_boundary():
    model = PCCModel(TDCR2)
    box = np.random.default_rng(4).uniform(0, TDCR2.max_tension, (300, 6))
    w = model.bending_from_tensions(box)
    assert np.all(S.reachable_scale(model, w) == 1.0)  # box shapes are reachable
    far = 3.0 * w
    tensions, clipped = S.minimal_tensions(model, far)
    scale = S.reachable_scale(model, far)
    assert np.array_equal(clipped, scale < 1.0) and clipped.any()
    assert np.all(tensions <= TDCR2.max_tension)
    inside, clipped_inside = S.minimal_tensions(model, far * scale[:, None, None])
    assert not clipped_inside.any()
    on_edge = scale < 1.0
    assert np.allclose(inside[on_edge].max(axis=-1), TDCR2.max_tension, rtol=1e-12)
    # positively homogeneous
    # positively homogeneous (where the limit binds)
    assert np.allclose(
        S.reachable_scale(model, 2.0 * far)[on_edge], 0.5 * scale[on_edge], rtol=1e-12
    )


def test_pretension_keeps_the_shape_and_floors_every_cable():
    for params in (TDCR2, MIXED):
        model = PCCModel(params)
        w = model.bending_from_tensions(
            np.random.default_rng(5).uniform(0, 0.5 * params.max_tension, (50, params.n_cables))
        )
        tensions, _ = S.minimal_tensions(model, w, pretension=0.3)
        assert np.all(tensions >= 0.3 - 1e-12)
        assert np.allclose(model.bending_from_tensions(tensions), w, atol=1e-13)


def test_one_section_layouts_limit_is_the_tension_box_boundary():
    grid = np.linspace(0, UNEVEN1.max_tension, 21)
    box = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), -1).reshape(-1, 3)
    theta, phi = S.arc_from_tensions(box, UNEVEN1)
    limit = S.bending_limit(phi, UNEVEN1)
    assert np.all(theta <= limit * (1 + 1e-12))
    at_corner = np.sum((box == 0) | (box == UNEVEN1.max_tension), axis=-1) == 3
    assert np.any(np.isclose(theta[at_corner], limit[at_corner], rtol=1e-12))
    t, c = S.tensions_from_arc(theta, phi, UNEVEN1)
    assert not c.any() and np.allclose(S.arc_from_tensions(t, UNEVEN1)[0], theta, atol=1e-12)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: S.arc_from_tensions([1.0, np.nan, 0.0], PAPER), "tensions"),
        (lambda: S.arc_from_tensions([1.0, -1.0, 0.0], PAPER), "tensions"),
        (lambda: S.tensions_from_arc(np.nan, 0.0, PAPER), "theta"),
        (lambda: S.tensions_from_arc(0.5, np.inf, PAPER), "phi"),
        (lambda: S.tensions_from_arc(-0.5, 0.0, PAPER), "theta"),
        (lambda: S.tensions_from_arc(0.5, 0.0, PAPER, pretension=-1.0), "pretension"),
        (lambda: S.bending_limit(0.0, PAPER, pretension=80.0), "pretension"),
        (lambda: S.bending_limit(np.nan, PAPER), "phi"),
        (lambda: S.bending_limit(0.0, TDCR2), "params"),
        (lambda: S.minimal_tensions(PCCModel(PAPER), [[np.nan, 0.0]]), "w"),
        (lambda: S.minimal_tensions(PAPER, [[0.0, 0.0]]), "model"),
        (lambda: S.reachable_scale(PCCModel(TDCR2), np.zeros((1, 2))), "w"),
    ],
)
def test_bad_input_raises_value_error_naming_it(call, name):
    with pytest.raises(ValueError, match=name):
        call()


# -- the one-section statics API (was tests/test_statics.py) -----------------------------------
P = RobotParams()


@pytest.mark.parametrize("cable", [0, 1, 2])
@pytest.mark.parametrize("tension", [1.0, 10.0, 40.0, 80.0])
def test_single_cable_bends_by_trl_over_ei_towards_that_cable(cable, tension):
    tensions = np.zeros(3)
    tensions[cable] = tension
    theta, phi = S.arc_from_tensions(tensions, P)
    assert theta == pytest.approx(tension * P.cable_radius * P.length / P.bending_stiffness)
    assert np.angle(np.exp(1j * (phi - CABLE_ANGLES[cable]))) == pytest.approx(0.0, abs=1e-12)


def test_common_mode_tension_does_not_bend():
    rng = np.random.default_rng(0)
    tensions = rng.uniform(0, 40, size=(100, 3))
    extra = rng.uniform(0, 40, size=(100, 1))
    t1, p1 = S.arc_from_tensions(tensions, P)
    t2, p2 = S.arc_from_tensions(tensions + extra, P)
    assert np.allclose(t1, t2, atol=1e-12)
    assert np.allclose(np.exp(1j * p1), np.exp(1j * p2), atol=1e-9)
    assert S.arc_from_tensions(np.full(3, 55.0), P)[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("pretension", [0.0, 5.0])
def test_tension_ik_reproduces_the_wanted_arc_with_non_negative_tensions(pretension):
    rng = np.random.default_rng(1)
    phi = rng.uniform(-np.pi, np.pi, 500)
    theta = rng.uniform(0, 1, 500) * S.bending_limit(phi, P, pretension)
    tensions, clipped = S.tensions_from_arc(theta, phi, P, pretension=pretension)
    assert not clipped.any()
    assert np.all(tensions >= pretension - 1e-12) and np.all(tensions <= P.max_tension + 1e-9)
    # minimal: the cable opposite the bend carries only the pretension
    assert np.allclose(tensions.min(axis=-1), pretension, atol=1e-9)
    theta_back, phi_back = S.arc_from_tensions(tensions, P)
    assert np.allclose(theta_back, theta, atol=1e-12)
    assert np.allclose(np.exp(1j * phi_back), np.exp(1j * phi), atol=1e-9)


def test_tension_ik_clips_and_reports_it():
    tensions, clipped = S.tensions_from_arc(2.0, 0.0, P)  # beyond the 79° limit
    assert clipped and tensions.max() == P.max_tension
    _, clipped = S.tensions_from_arc(1.0, 0.0, P)
    assert not clipped


def test_bending_limit_matches_brute_force_over_the_tension_cube():
    grid = np.linspace(0, P.max_tension, 41)
    tensions = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), axis=-1).reshape(-1, 3)
    theta, phi = S.arc_from_tensions(tensions, P)
    limit = S.bending_limit(phi, P)
    assert np.all(theta <= limit + 1e-9)  # no tension combination exceeds the limit
    # the limit is attained at the hexagon's vertices (one or two cables at the maximum)
    for k in range(6):
        vertex = np.radians(60 * k)
        assert S.bending_limit(vertex, P) == pytest.approx(P.max_bending_angle)
        assert S.bending_limit(vertex + np.radians(30), P) == pytest.approx(
            P.max_bending_angle * np.cos(np.radians(30))
        )


def test_bad_input():
    with pytest.raises(ValueError, match="tensions"):
        S.arc_from_tensions([1.0, np.nan, 0.0], P)
    with pytest.raises(ValueError, match="pretension"):
        S.tensions_from_arc(0.5, 0.0, P, pretension=-1.0)
    with pytest.raises(ValueError, match="pretension"):
        S.bending_limit(0.0, P, pretension=80.0)
