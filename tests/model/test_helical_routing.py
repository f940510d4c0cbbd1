"""Helical tendon routing (``RobotParams.cable_pitch``): the description, the constant-curvature
model and the discrete-disk backends agree on what a helix does."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.backends.mujoco import MuJoCoBackend
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.discrete import DiscreteBackbone
from cdcr_gym.model.params import RobotParams

V4 = RobotParams.preset("ftdcr_v4")
#: a strong helix: 4 rad/m, 43° over the robot's 186.5 mm
PITCH = -4.0


def _helical(pitch: float = PITCH) -> RobotParams:
    return replace(V4, cable_pitch=pitch)


def test_parallel_routing_is_unchanged_and_not_written():
    vectors = V4.section_cable_vectors()
    owner = np.asarray(V4.cable_section)
    beta = np.asarray(V4.cable_angles)
    r = np.asarray(V4.cable_radii)
    for j in range(V4.n_sections):
        through = owner >= j
        want = r[through, None] * np.stack([np.cos(beta), np.sin(beta)], -1)[through]
        np.testing.assert_array_equal(vectors[through, j], want)
        np.testing.assert_array_equal(vectors[~through, j], 0.0)
    assert "cable_pitch" not in V4.to_yaml()


def test_pitch_round_trips_and_bad_values_name_the_field():
    helix = _helical()
    text = helix.to_yaml()
    assert "cable_pitch: -4.0" in text
    assert RobotParams.from_yaml(text) == helix
    for bad in (math.nan, math.inf, "1", True):
        with pytest.raises(ValueError, match="cable_pitch"):
            replace(V4, cable_pitch=bad)


def test_section_vectors_are_the_mean_of_the_helix_over_each_section():
    """v_ij = the mean over section j of r·(cos, sin)(β + p·z), by quadrature."""
    helix = _helical()
    vectors = helix.section_cable_vectors()
    starts = np.concatenate([[0.0], np.cumsum(helix.section_lengths)])
    z = np.linspace(0.0, 1.0, 20001)
    for i, (beta, r, own) in enumerate(
        zip(helix.cable_angles, helix.cable_radii, helix.cable_section)
    ):
        for j in range(own + 1):
            zz = starts[j] + z * helix.section_lengths[j]
            mean = np.trapezoid(
                np.stack([np.cos(beta + PITCH * zz), np.sin(beta + PITCH * zz)]), z, axis=1
            )
            np.testing.assert_allclose(vectors[i, j], r * mean, rtol=0, atol=1e-12)


def test_discrete_pinholes_turn_by_the_pitch_from_disk_to_disk():
    helix = _helical()
    chain = DiscreteBackbone(helix)
    z = helix.disk_arc_positions()
    assert z[0] == 0.0 and z[-1] == pytest.approx(helix.length, abs=1e-15)
    angles = np.arctan2(chain.disk_pinholes[..., 1], chain.disk_pinholes[..., 0])
    want = np.asarray(helix.cable_angles)[None, :] + PITCH * z[:, None]
    np.testing.assert_allclose(np.angle(np.exp(1j * (angles - want))), 0.0, atol=1e-12)
    np.testing.assert_allclose(
        np.hypot(chain.disk_pinholes[..., 0], chain.disk_pinholes[..., 1]),
        np.broadcast_to(np.asarray(helix.cable_radii), angles.shape),
    )
    # parallel routing: the same pinholes on every disk
    flat = DiscreteBackbone(V4).disk_pinholes
    np.testing.assert_array_equal(flat, np.broadcast_to(flat[0], flat.shape))


def _cases(params: RobotParams) -> np.ndarray:
    """A base tendon, a distal tendon and a middle and a distal tendon together (N)."""
    t = np.zeros((3, params.n_cables))
    t[0, 0] = 4.0
    t[1, 7] = 3.0
    t[2, 4], t[2, 8] = 3.0, 2.0
    return t


def test_mujoco_and_bullet_see_the_helix_the_constant_curvature_model_sees():
    """What the helix changes in the settled tips (no gravity). MuJoCo's default (one link per
    disk span, via-points on the helix) is converged: within 0.1 mm of eight links per span
    with the cable straight from pinhole to pinhole. Bullet settles where MuJoCo's same
    discretisation does (one routing geometry). The constant-curvature model, which sees each
    section's mean helix, gets the change to 12 % of its size (measured 7–9 %: a helical cable
    bends its section along a turning direction, not along one arc)."""
    tips = {}
    for name, params in (("parallel", V4), ("helix", _helical())):
        t = _cases(params)
        tips["ccka", name] = AnalyticBackend(params).equilibrium(t).tip
        backends = {
            "mujoco": MuJoCoBackend(params, gravity=False),
            "fine": MuJoCoBackend(params, gravity=False, links_per_span=8, routing="disk"),
            "cardan": MuJoCoBackend(params, gravity=False, links_per_span=1, joint="cardan"),
            "bullet": BulletBackend(params, gravity=False),
        }
        try:
            for key, backend in backends.items():
                tips[key, name] = backend.equilibrium(t).tip
        finally:
            for backend in backends.values():
                backend.close()
    np.testing.assert_allclose(tips["mujoco", "helix"], tips["fine", "helix"], atol=1e-4)
    np.testing.assert_allclose(tips["bullet", "helix"], tips["cardan", "helix"], atol=1e-9)
    change_ccka = tips["ccka", "helix"] - tips["ccka", "parallel"]
    change_mj = tips["mujoco", "helix"] - tips["mujoco", "parallel"]
    size = np.linalg.norm(change_ccka, axis=1)
    assert np.all(size > 5e-3), size  # the helix turns these bends by millimetres
    np.testing.assert_array_less(np.linalg.norm(change_mj - change_ccka, axis=1), 0.12 * size)


def test_pcc_lengths_and_statics_use_the_section_vectors():
    helix = _helical()
    model = PCCModel(helix)
    t = _cases(helix)
    w = model.bending_from_tensions(t)
    vectors = helix.section_cable_vectors()
    want = np.einsum("mc,csk->msk", t, vectors) * (
        np.asarray(helix.section_lengths)[None, :, None] / helix.bending_stiffness
    )
    np.testing.assert_allclose(w, want, rtol=1e-12, atol=1e-15)
    lengths = model.lengths_from_bending(w)
    np.testing.assert_allclose(
        lengths, model.straight_lengths - np.einsum("msk,csk->mc", w, vectors), atol=1e-15
    )
    # and lengths → bending inverts it (the sequential least squares with the turned vectors)
    np.testing.assert_allclose(model.bending_from_lengths(lengths), w, atol=1e-12)


def test_a_helical_robot_is_a_gym_robot_and_its_reach_oracle_reaches(tmp_path):
    """A params.yaml with a pitch builds the env; the reach oracle (IK on the same helical CCKA
    model) brings the tip onto goals in the displacement mode; an oracle that solves the IK
    for the parallel robot misses them."""
    import gymnasium as gym

    import cdcr_gym  # noqa: F401  (registers the envs)
    from cdcr_gym.controllers import AnalyticIKController

    path = tmp_path / "helix.yaml"
    _helical().to_yaml(path)
    env = gym.make("cdcr_gym/CCKAReach-v0", params=str(path), action_mode="displacement")
    assert env.unwrapped.params.cable_pitch == PITCH
    oracle = AnalyticIKController.from_env(env)
    naive = AnalyticIKController(V4, env.unwrapped.observation_spec, "displacement")
    try:
        missed = []
        for seed in range(3):
            for controller in (oracle, naive):
                obs, info = env.reset(seed=seed)
                for _ in range(5):
                    obs, _, _, _, info = env.step(controller(obs))
                if controller is oracle:
                    assert info["distance"] < 1e-4, seed
                else:
                    missed.append(info["distance"])
        assert max(missed) > 1e-3
    finally:
        env.close()


def test_friction_pinholes_take_one_angle_per_disk():
    """``pinhole_positions`` with the helix's per-disk angles gives the discrete chain's
    pinholes of the straight robot (frames: identity, centres on the axis)."""
    from cdcr_gym.model.friction import pinhole_positions

    helix = _helical()
    z = helix.disk_arc_positions()
    centres = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=-1)
    frames = np.broadcast_to(np.eye(3), (z.size, 3, 3))
    angles = helix.cable_angles_at_disks()
    chain = DiscreteBackbone(helix)
    for i in (0, 8):
        pins = pinhole_positions(centres, frames, helix.cable_radii[i], angles[:, i])
        np.testing.assert_allclose(pins[:, :2], chain.disk_pinholes[:, i, :2], atol=1e-15)
        np.testing.assert_allclose(pins[:, 2], z, atol=1e-15)
    # one angle for every disk: as before
    one = pinhole_positions(centres, frames, 0.01, 0.5)
    np.testing.assert_allclose(one[:, 0], 0.01 * np.cos(0.5))
