"""How ``tests/data/legacy_*.npz`` were written: the old one-section model's outputs on fixed
inputs (the tests compare today's model with them).

Run once, at commit "Replace tests/legacy by stored arrays" 's parent, where the old modules
still lived in ``tests/legacy/`` (``kinematics_v0``, ``statics_v0``, ``workspace_v0``); they were
deleted right after. Kept for provenance: it cannot run without them (``git show`` that parent's
``tests/legacy`` to rerun it). Do not regenerate the arrays from today's model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from legacy import kinematics_v0 as old_kinematics
from legacy import statics_v0 as old_statics
from legacy import workspace_v0 as old_workspace

from cdcr_gym.model.params import RobotParams

DATA = Path(__file__).parent
PAPER = RobotParams()
ELL, R = PAPER.length, PAPER.cable_radius


def arcs(n: int, seed: int, top: float = np.pi, special=(0.0, 1e-300, 1e-12, 1e-6, np.pi)):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, top, n)
    theta[: len(special)] = special
    return theta, rng.uniform(-np.pi, np.pi, n)


def kinematics() -> dict[str, np.ndarray]:
    k = old_kinematics
    theta, phi = arcs(2000, 0)
    lengths = k.lengths_from_arc(theta, phi, ELL, R)
    points = np.random.default_rng(1).uniform([-0.6, -0.6, -0.2], [0.6, 0.6, 0.7], (300, 3))
    points = np.concatenate([points, k.tip_from_arc(theta * 0.999, phi, ELL)])
    out = {
        "theta": theta,
        "phi": phi,
        "lengths_from_arc": lengths,
        "tip_from_arc": k.tip_from_arc(theta, phi, ELL),
        "forward_kinematics": k.forward_kinematics(lengths, R),
        "tip_rotation": k.tip_rotation(theta, phi),
        "tip_pose": k.tip_pose(theta, phi, ELL),
        "backbone_points_50_9": k.backbone_points(theta[:50], phi[:50], ELL, 9),
        "points": points,
    }
    for i, a in enumerate(k.arc_from_lengths(lengths, R)):
        out[f"arc_from_lengths_{i}"] = a
    for i, a in enumerate(k.arc_from_tip(points, ELL)):
        out[f"arc_from_tip_{i}"] = a
    for i, a in enumerate(k.inverse_kinematics(points, ELL, R, return_residual=True)):
        out[f"inverse_kinematics_{i}"] = a
    return out


def statics(ik_theta: np.ndarray, ik_phi: np.ndarray) -> dict[str, np.ndarray]:
    s, k = old_statics, old_kinematics
    out: dict[str, np.ndarray] = {"cable_directions": s.CABLE_DIRECTIONS}
    theta, phi = arcs(2000, 0, 1.6, (0.0, 0.0))
    out["tension_ik_theta"], out["tension_ik_phi"] = theta, phi
    for p in (0.0, 5.0):
        t, c = s.tensions_from_arc(theta, phi, PAPER, pretension=p)
        out[f"tensions_from_arc_{p:g}"], out[f"clipped_{p:g}"] = t, c
    theta, phi = arcs(2000, 1, 1.6, (0.0, 0.0))
    out["scale_theta"], out["scale_phi"] = theta, phi
    w = np.stack([theta * np.cos(phi), theta * np.sin(phi)], axis=-1)
    stiffness = PAPER.bending_stiffness / (PAPER.cable_radius * PAPER.length)
    out["workspace_scale"] = s._workspace_scale(w[:, 0], w[:, 1], stiffness, PAPER.max_tension)
    for p in (0.0, 3.0):
        out[f"bending_limit_{p:g}"] = s.bending_limit(phi, PAPER, p)
    tensions = np.random.default_rng(2).uniform(0, 80, (500, 3))
    out["arc_tensions"] = tensions
    for i, a in enumerate(s.arc_from_tensions(tensions, PAPER)):
        out[f"arc_from_tensions_{i}"] = a
    # the IK tests: goals on the reachable surface (arcs given), and goals off it
    goals = k.tip_from_arc(ik_theta, ik_phi, ELL)
    th, ph, _ = k.arc_from_tip(goals, ELL)
    out["ik_goals"] = goals
    out["ik_tensions"] = s.tensions_from_arc(th, ph, PAPER)[0]
    far = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [10.0, 10.0, 10.0]])
    th, ph, _ = k.arc_from_tip(far, ELL)
    out["far_goals"], out["far_theta"], out["far_limit"] = far, th, s.bending_limit(ph, PAPER)
    return out


def workspace() -> dict[str, np.ndarray]:
    w, k = old_workspace, old_kinematics
    out: dict[str, np.ndarray] = {}
    out["sample_arcs_9_0"], out["sample_arcs_9_1"] = w.sample_arcs(
        np.random.default_rng(9), 3000, PAPER
    )
    out["sample_arcs_each_0"], out["sample_arcs_each_1"] = w.sample_arcs_each(
        [np.random.default_rng(i) for i in range(40)], PAPER
    )
    theta, phi = np.linspace(0, 2, 50), np.linspace(-3, 3, 50)
    out["area_density"] = w.area_density(theta)
    for i, a in enumerate(w.clip_to_workspace(theta, phi, PAPER)):
        out[f"clip_to_workspace_{i}"] = a
    rng = np.random.default_rng(3)
    theta, phi = w.sample_arcs(rng, 500, PAPER)
    out["tips_3_500"] = k.tip_from_arc(theta, phi, ELL)
    out["next_random_3_500"] = np.array(rng.random())
    return out


if __name__ == "__main__":
    from cdcr_gym.model.workspace import sample_arcs

    ik_theta, ik_phi = sample_arcs(np.random.default_rng(0), 500, PAPER)
    for name, arrays in (
        ("kinematics", kinematics()),
        ("statics", statics(ik_theta, ik_phi)),
        ("workspace", workspace()),
    ):
        np.savez_compressed(DATA / f"legacy_{name}.npz", **arrays)
        print(name, len(arrays), "arrays")
