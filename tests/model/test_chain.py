"""PCCModel against an independent numerical integration of the backbone and cable paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams, SectionParams

pytestmark = pytest.mark.filterwarnings("error")

DEG = math.pi / 180.0


def _robots():
    four = SectionParams(
        length=0.15,
        n_disks=5,
        cable_radius=0.012,
        cable_angles=(10 * DEG, 95 * DEG, 200 * DEG, 280 * DEG),
    )
    three_uneven = SectionParams(
        length=0.12, n_disks=4, cable_radius=0.008, cable_angles=(0.0, 100 * DEG, 230 * DEG)
    )
    three = SectionParams(
        length=0.1, n_disks=3, cable_radius=0.005, cable_angles=(45 * DEG, 165 * DEG, 285 * DEG)
    )
    return {
        "paper": RobotParams(),
        "tdcr2": RobotParams.preset("tdcr2"),
        "three_mixed": RobotParams(
            sections=(four, three_uneven, three),
            backbone_diameter=0.002,
            youngs_modulus=60e9,
            max_tension=5.0,
            disk_radius=0.02,
        ),
        "one_four": RobotParams(
            sections=(four,),
            backbone_diameter=0.002,
            youngs_modulus=60e9,
            max_tension=5.0,
            disk_radius=0.02,
        ),
    }


ROBOTS = _robots()


def _random_bending(model, n, seed):
    """Bending vectors with θ_j up to π (a few exactly straight sections and rows)."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, np.pi, (n, model.n_sections))
    phi = rng.uniform(-np.pi, np.pi, (n, model.n_sections))
    theta[0] = 0.0
    theta[1, 0] = 0.0
    theta[2, -1] = 1e-9
    return np.stack([theta * np.cos(phi), theta * np.sin(phi)], axis=-1)


def _hat(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _integrate(params, w, steps_per_section=400):
    """RK4 on dR/ds = R[ω]×, dp/ds = R e_z with ω = (−w_y, w_x, 0)/ℓ_j per section.

    Returns the frames (R, p) at every section end and, per section, the Gauss–Legendre
    quadrature nodes' rotations (for the cable speeds). Independent of the closed forms.
    """
    nodes, weights = np.polynomial.legendre.leggauss(8)
    R, p = np.eye(3), np.zeros(3)
    ends, quad = [(R, p)], []
    for j, section in enumerate(params.sections):
        ell = section.length
        omega = np.array([-w[j, 1], w[j, 0], 0.0]) / ell
        K = _hat(omega)
        h = ell / steps_per_section

        def f(state, K=K):
            Rm = state[:9].reshape(3, 3)
            return np.concatenate([(Rm @ K).ravel(), Rm[:, 2]])

        state = np.concatenate([R.ravel(), p])
        for _ in range(steps_per_section):
            k1 = f(state)
            k2 = f(state + 0.5 * h * k1)
            k3 = f(state + 0.5 * h * k2)
            k4 = f(state + h * k3)
            state = state + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        quad.append((ell, omega, 0.5 * ell * weights))
        R, p = state[:9].reshape(3, 3), state[9:]
        ends.append((R, p))
    return ends, quad


def _cable_length(params, quad, cable):
    """∫ |d/ds (p + R·o)| ds over the sections the cable passes, by quadrature.

    The speed is |R (e_z + ω × o)| = |e_z + ω × o| (o = the cable's offset in the disk frame).
    """
    beta = params.cable_angles[cable]
    r = params.cable_radii[cable]
    offset = r * np.array([math.cos(beta), math.sin(beta), 0.0])
    total = 0.0
    for j in range(params.cable_section[cable] + 1):
        _, omega, w8 = quad[j]
        speed = np.linalg.norm(np.array([0.0, 0.0, 1.0]) + np.cross(omega, offset))
        total += float(np.sum(w8 * speed))
    return total


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_tip_direction_frames_and_lengths_match_numerical_integration(name):
    params = ROBOTS[name]
    model = PCCModel(params)
    w = _random_bending(model, 12, seed=len(name))
    tips = model.tip_from_bending(w)
    dirs = model.tip_direction_from_bending(w)
    frames = model.section_frames(w)
    lengths = model.lengths_from_bending(w)
    for n in range(len(w)):
        ends, quad = _integrate(params, w[n])
        R_tip, p_tip = ends[-1]
        assert np.linalg.norm(tips[n] - p_tip) <= 1e-9
        assert np.linalg.norm(dirs[n] - R_tip[:, 2]) <= 1e-9
        for j, (R, p) in enumerate(ends):
            assert np.max(np.abs(frames[n, j, :3, :3] - R)) <= 1e-9
            assert np.linalg.norm(frames[n, j, :3, 3] - p) <= 1e-9
        for i in range(model.n_cables):
            assert abs(lengths[n, i] - _cable_length(params, quad, i)) <= 1e-9


def test_the_integration_check_detects_a_wrong_model():
    # Negative control: composing the sections with torsion (R_j = Rz(φ)Ry(θ), no Rz(−φ))
    # must fail the same tolerance.
    params = ROBOTS["tdcr2"]
    model = PCCModel(params)
    w = _random_bending(model, 6, seed=3)[3:]
    ends, _ = _integrate(params, w[0])
    theta, phi = model.arcs_from_bending(w[0])

    def rz(a):
        return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])

    def ry(a):
        return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])

    R, p = np.eye(3), np.zeros(3)
    for j in range(2):
        ell = params.section_lengths[j]
        local = (
            ell
            / theta[j]
            * np.array(
                [
                    (1 - math.cos(theta[j])) * math.cos(phi[j]),
                    (1 - math.cos(theta[j])) * math.sin(phi[j]),
                    math.sin(theta[j]),
                ]
            )
        )
        p = p + R @ local
        R = R @ rz(phi[j]) @ ry(theta[j])
    assert np.linalg.norm(p - ends[-1][1]) > 1e-6
    assert np.linalg.norm(model.tip_from_bending(w[0]) - ends[-1][1]) <= 1e-9


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_straight_robot_is_exact(name):
    model = PCCModel(ROBOTS[name])
    w = np.zeros((2, model.n_sections, 2))
    total = float(np.sum(model.section_lengths))
    assert np.array_equal(model.tip_from_bending(w), np.tile([0.0, 0.0, total], (2, 1)))
    assert np.array_equal(model.tip_direction_from_bending(w), np.tile([0.0, 0.0, 1.0], (2, 1)))
    assert np.array_equal(model.lengths_from_bending(w), np.tile(model.straight_lengths, (2, 1)))
    theta, phi = model.arcs_from_bending(w)
    assert np.all(theta == 0.0) and np.all(phi == 0.0)
    frames = model.section_frames(w)
    assert np.array_equal(
        frames[0, :, :3, :3], np.broadcast_to(np.eye(3), (model.n_sections + 1, 3, 3))
    )
    centres, rotations = model.disk_frames(w)
    assert np.all(np.isfinite(centres)) and np.all(np.isfinite(rotations))
    assert np.all(centres[..., :2] == 0.0)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_batched_equals_per_row(name):
    model = PCCModel(ROBOTS[name])
    w = _random_bending(model, 12, seed=7).reshape(3, 4, model.n_sections, 2)
    tensions = np.random.default_rng(1).uniform(0, 5, (3, 4, model.n_cables))
    batched = (
        model.tip_from_bending(w),
        model.tip_direction_from_bending(w),
        model.lengths_from_bending(w),
        model.section_frames(w),
        model.bending_from_tensions(tensions),
    )
    tip, direction = model.tip_and_direction_from_bending(w)
    assert np.array_equal(tip, batched[0]) and np.array_equal(direction, batched[1])
    lengths = batched[2]
    back = model.bending_from_lengths(lengths)
    for i in range(3):
        for j in range(4):
            row = (
                model.tip_from_bending(w[i, j]),
                model.tip_direction_from_bending(w[i, j]),
                model.lengths_from_bending(w[i, j]),
                model.section_frames(w[i, j]),
                model.bending_from_tensions(tensions[i, j]),
            )
            for a, b in zip(row, batched):
                assert np.allclose(a, b[i, j], rtol=0, atol=1e-15)
            assert np.allclose(model.bending_from_lengths(lengths[i, j]), back[i, j], atol=1e-15)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_lengths_round_trip_and_common_mode_does_not_bend(name):
    model = PCCModel(ROBOTS[name])
    w = _random_bending(model, 50, seed=11)
    lengths = model.lengths_from_bending(w)
    assert np.allclose(model.bending_from_lengths(lengths), w, rtol=0, atol=1e-11)
    offset = np.zeros(model.n_cables)
    offset[model.cable_section == model.n_sections - 1] = 1e-3  # the distal cables, common mode
    assert np.allclose(model.bending_from_lengths(lengths + offset), w, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_tension_statics_against_an_explicit_sum(name):
    """w_j = (ℓ_j/EI)·Σ over cables of sections >= j of T_i r_i u_i, summed by loops."""
    params = ROBOTS[name]
    model = PCCModel(params)
    tensions = np.random.default_rng(2).uniform(0, params.max_tension, (20, params.n_cables))
    got = model.bending_from_tensions(tensions)
    ei = params.youngs_modulus * math.pi * params.backbone_diameter**4 / 64.0
    for n in range(len(tensions)):
        for j in range(params.n_sections):
            moment = np.zeros(2)
            for i in range(params.n_cables):
                if params.cable_section[i] >= j:  # the cable runs through section j
                    b, r = params.cable_angles[i], params.cable_radii[i]
                    moment += tensions[n, i] * r * np.array([math.cos(b), math.sin(b)])
            expected = moment * params.section_lengths[j] / ei
            assert np.allclose(got[n, j], expected, rtol=1e-13, atol=1e-15)


def test_distal_cable_bends_the_proximal_section_as_much_per_length():
    params = ROBOTS["tdcr2"]
    model = PCCModel(params)
    tensions = np.zeros(6)
    tensions[3] = 2.0  # a distal cable
    w = model.bending_from_tensions(tensions)
    assert np.linalg.norm(w[0]) > 0 and np.allclose(w[0], w[1])
    tensions = np.zeros(6)
    tensions[0] = 2.0  # a proximal cable
    w = model.bending_from_tensions(tensions)
    assert np.linalg.norm(w[0]) > 0 and np.all(w[1] == 0.0)


def test_arcs_round_trip():
    model = PCCModel(ROBOTS["three_mixed"])
    w = _random_bending(model, 30, seed=4)
    theta, phi = model.arcs_from_bending(w)
    assert np.allclose(model.bending_from_arcs(theta, phi), w, atol=1e-15)
    assert np.all(theta >= 0.0) and np.all(phi[theta == 0.0] == 0.0)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_disk_frames_and_backbone_points(name):
    params = ROBOTS[name]
    model = PCCModel(params)
    w = _random_bending(model, 4, seed=5)[3]
    centres, rotations = model.disk_frames(w)
    assert centres.shape == (params.n_disks + 1, 3) and rotations.shape == (
        params.n_disks + 1,
        3,
        3,
    )
    assert np.allclose(centres[0], 0.0) and np.allclose(rotations[0], np.eye(3))
    frames = model.section_frames(w)
    ends = np.cumsum([s.n_disks for s in params.sections])
    assert np.allclose(centres[ends], frames[1:, :3, 3], atol=1e-15)
    assert np.allclose(rotations[ends], frames[1:, :3, :3], atol=1e-15)
    assert np.allclose(rotations @ np.swapaxes(rotations, -1, -2), np.eye(3), atol=1e-12)
    # consecutive disks of a section sit at equal chords (equal arc spacing on one arc)
    start = 0
    for end in ends:
        chords = np.linalg.norm(np.diff(centres[start : end + 1], axis=0), axis=-1)
        assert np.allclose(chords, chords[0], rtol=1e-12)
        start = end
    points = model.backbone_points(w, points_per_section=7)
    assert np.allclose(points[0], 0.0) and np.allclose(points[-1], model.tip_from_bending(w))
    for c in centres:  # every disk station is a backbone point
        assert np.min(np.linalg.norm(points - c, axis=-1)) <= 1e-15
    assert model.backbone_points(np.stack([w, w])).shape[0] == 2


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda m: m.bending_from_tensions([1.0, np.nan, 0.0]), "tensions"),
        (lambda m: m.bending_from_tensions([1.0, 0.0]), "tensions"),
        (lambda m: m.tip_from_bending([[np.inf, 0.0]]), "w"),
        (lambda m: m.tip_direction_from_bending([[np.nan, 0.0]]), "w"),
        (lambda m: m.lengths_from_bending([[0.1, np.nan]]), "w"),
        (lambda m: m.section_frames([[0.1, 0.2, 0.3]]), "w"),
        (lambda m: m.bending_from_lengths([0.6, 0.6, np.nan]), "lengths"),
        (lambda m: m.bending_from_lengths([0.6, 0.6, -0.1]), "lengths"),
        (lambda m: m.backbone_points([[0.1, 0.2]], points_per_section=0), "points_per_section"),
        (lambda m: PCCModel("paper"), "params"),
    ],
)
def test_bad_input_raises_value_error_naming_it(call, name):
    with pytest.raises(ValueError, match=name):
        call(PCCModel(RobotParams()))


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_field_major_kernels_match_the_public_api(name):
    """forward_rows (batched rows and its one-robot Python-float path) against
    tip_and_direction_from_bending / lengths_from_bending, straight robot included."""
    model = PCCModel(ROBOTS[name])
    w = _random_bending(model, 9, seed=7)
    w[0] = 0.0
    tip, direction = model.tip_and_direction_from_bending(w)
    lengths = model.lengths_from_bending(w)
    comp = np.ascontiguousarray(w.reshape(9, -1).T)
    rows = model.forward_rows(comp)
    for got, want in zip(rows, (tip, direction, lengths)):
        np.testing.assert_allclose(got.T, want, rtol=0.0, atol=1e-15)
    for k in range(9):
        one = model.forward_rows(comp[:, k : k + 1].copy())
        for got, want in zip(one, (tip, direction, lengths)):
            np.testing.assert_allclose(got[:, 0], want[k], rtol=0.0, atol=1e-15)
    t = np.random.default_rng(1).uniform(0.0, 30.0, (4, model.n_cables))
    np.testing.assert_allclose(
        model.bending_rows_from_tensions(t).T,
        model.bending_from_tensions(t).reshape(4, -1),
        rtol=0.0,
        atol=1e-15,
    )


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_tension_rows_match_bending_then_forward(name):
    """forward_rows_from_tensions (bending and length changes from one product) gives the
    bending rows and forward_rows of bending_rows_from_tensions, straight robot included."""
    model = PCCModel(ROBOTS[name])
    t = np.random.default_rng(3).uniform(0.0, model.params.max_tension, (6, model.n_cables))
    t[0] = 0.0
    comp, rows = model.forward_rows_from_tensions(t)
    want_comp = model.bending_rows_from_tensions(t)
    np.testing.assert_allclose(comp, want_comp, rtol=0.0, atol=1e-15)
    for got, want in zip(rows, model.forward_rows(want_comp)):
        np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-15)
    np.testing.assert_array_equal(rows[2][:, 0], model.straight_lengths)


def test_one_section_kernel_against_the_closed_form_arc_up_to_two_pi():
    """Tip and tangent of one arc (θ, φ) for θ from 0 (and 1e-300) through π to 1.9π against
    p = ℓ(2 sin²(θ/2)/θ (cos φ, sin φ), sin θ/θ), t = (sin θ cos φ, sin θ sin φ, cos θ)."""
    model = PCCModel(RobotParams())
    ell = model.section_lengths[0]
    theta = np.array([0.0, 1e-300, 1e-9, 1e-4, 0.5, np.pi - 1e-9, np.pi, np.pi + 1e-9, 5.9])
    phi = np.linspace(-3.0, 3.0, theta.size)
    w = (theta[:, None] * np.stack([np.cos(phi), np.sin(phi)], -1))[:, None, :]
    tip, direction = model.tip_and_direction_from_bending(w)
    with np.errstate(invalid="ignore", divide="ignore"):
        radial = np.where(theta > 0, 2.0 * np.sin(theta / 2) ** 2 / theta, 0.0)
        axial = np.where(theta > 0, np.sin(theta) / theta, 1.0)
    want_tip = ell * np.stack([radial * np.cos(phi), radial * np.sin(phi), axial], -1)
    want_dir = np.stack(
        [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1
    )
    np.testing.assert_allclose(tip, want_tip, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(direction, want_dir, rtol=0.0, atol=1e-15)
    assert np.isfinite(tip).all() and np.isfinite(direction).all()
