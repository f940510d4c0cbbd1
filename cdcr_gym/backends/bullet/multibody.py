"""The pybullet multibody of the discretised backbone (construction only; no dynamics here).

The base (base disk, first half link) is fixed at the world origin with orientation
``base_orientation``; each Cardan joint of :class:`~cdcr_gym.model.discrete.DiscreteBackbone`
is a revolute about X into a massless intermediate link at the joint, then a revolute about Y
into the real link (mass, COM and principal inertia from the chain model; no collision shapes,
so no contacts). pybullet's API caps a multibody at 128 coordinates including the base's 7,
hence at most :data:`MAX_JOINTS` Cardan joints (links) per robot.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from cdcr_gym.backends.base import MAX_JOINT_RATE
from cdcr_gym.model.discrete import DiscreteBackbone
from cdcr_gym.model.params import STANDARD_GRAVITY

__all__ = ["MAX_JOINTS", "Multibody", "build_multibody"]

#: Most Cardan joints (links: Σ n_disks × links_per_span) one pybullet multibody can hold:
#: pybullet's shared-memory state holds 128 coordinates per body, 7 of them the base pose, so
#: joint states from index 121 on are lost (measured with pybullet 3.2.7): 60 joints = 120
#: revolutes.
MAX_JOINTS = 60

_GREY, _ORANGE = (0.55, 0.57, 0.62, 1.0), (0.95, 0.55, 0.1, 1.0)


@dataclass(frozen=True)
class Multibody:
    """The ids of the robot body and of the goal marker in one pybullet client."""

    body: int
    goal_marker: int


def build_multibody(
    pb: ModuleType,
    client: int,
    chain: DiscreteBackbone,
    *,
    base_orientation: Sequence[float],
    physics_timestep: float,
    gravity: bool,
) -> Multibody:
    """Configure the client (time step, gravity) and create the chain's multibody in it.

    Sets every link's mass, COM and inertia from ``chain`` (checked back from pybullet), turns
    off pybullet's own damping, velocity clamps, sleeping and joint motors (which would act as
    velocity dampers), and adds the goal marker (a sphere parked out of sight).

    Raises:
        RuntimeError: if pybullet did not take a link's inertia.
    """
    cid = client
    pb.setPhysicsEngineParameter(
        fixedTimeStep=physics_timestep,
        numSubSteps=0,
        deterministicOverlappingPairs=1,
        physicsClientId=cid,
    )
    pb.setGravity(0.0, 0.0, -STANDARD_GRAVITY if gravity else 0.0, physicsClientId=cid)
    vis = _visuals(pb, cid, chain)
    masses: list[float] = []
    vis_idx: list[int] = []
    parents: list[int] = []
    pos: list[tuple[float, float, float]] = []
    inertial_pos: list[tuple[float, float, float]] = []
    axes: list[tuple[float, float, float]] = []
    n_links, m = chain.n_links, chain.links_per_span
    lead = (
        chain.segment_lengths[0] * 0.5,
        *(0.5 * chain.segment_lengths[:-1] + 0.5 * chain.segment_lengths[1:]),
    )
    for j in range(1, n_links + 1):
        mass, z_c = float(chain.link_masses[j - 1]), float(chain.link_com_offsets[j - 1])
        # X joint into the massless intermediate link, at the joint
        masses.append(0.0)
        vis_idx.append(-1)
        pos.append((0.0, 0.0, float(lead[j - 1])))
        inertial_pos.append((0.0, 0.0, 0.0))
        parents.append(len(parents))
        axes.append((1.0, 0.0, 0.0))
        # Y joint into the real link
        masses.append(mass)
        kind = "tip" if j == n_links else ("disk" if j % m == 0 else "rod")
        vis_idx.append(vis[(kind, j - 1)])
        pos.append((0.0, 0.0, 0.0))
        inertial_pos.append((0.0, 0.0, z_c))
        parents.append(len(parents))
        axes.append((0.0, 1.0, 0.0))
    n2 = chain.n_dof
    body = pb.createMultiBody(
        baseMass=0.0,
        baseCollisionShapeIndex=-1,
        baseVisualShapeIndex=vis["base"],
        basePosition=(0.0, 0.0, 0.0),
        baseOrientation=tuple(base_orientation),
        linkMasses=masses,
        linkCollisionShapeIndices=[-1] * n2,
        linkVisualShapeIndices=vis_idx,
        linkPositions=pos,
        linkOrientations=[(0.0, 0.0, 0.0, 1.0)] * n2,
        linkInertialFramePositions=inertial_pos,
        linkInertialFrameOrientations=[(0.0, 0.0, 0.0, 1.0)] * n2,
        linkParentIndices=parents,
        linkJointTypes=[pb.JOINT_REVOLUTE] * n2,
        linkJointAxis=axes,
        physicsClientId=cid,
    )
    # No collision shapes, so pybullet would give the links zero inertia: set it. No built-in
    # velocity damping, no velocity clamp below the divergence limit, no sleeping.
    pb.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
    for i in range(n2):
        pb.changeDynamics(
            body,
            i,
            linearDamping=0.0,
            angularDamping=0.0,
            jointDamping=0.0,
            maxJointVelocity=10.0 * MAX_JOINT_RATE,
            activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
            physicsClientId=cid,
        )
        if i % 2 == 1:
            # a separate call: combined with the damping keywords above, pybullet 3.2.7
            # silently ignores localInertiaDiagonal
            pb.changeDynamics(
                body,
                i,
                localInertiaDiagonal=chain.link_inertias[i // 2].tolist(),
                physicsClientId=cid,
            )
    for i in range(1, n2, 2):
        info = pb.getDynamicsInfo(body, i, physicsClientId=cid)
        if not np.allclose(info[2], chain.link_inertias[i // 2], rtol=1e-9, atol=0.0):
            raise RuntimeError(f"pybullet did not take the inertia of link {i}: {info[2]}")
    pb.setJointMotorControlArray(
        body, list(range(n2)), pb.VELOCITY_CONTROL, forces=[0.0] * n2, physicsClientId=cid
    )
    goal = pb.createMultiBody(
        baseMass=0.0,
        baseVisualShapeIndex=vis["goal"],
        basePosition=(0.0, 0.0, -100.0),
        physicsClientId=cid,
    )
    for link in range(-1, n2):
        colour = _ORANGE if link == n2 - 1 else _GREY
        pb.changeVisualShape(body, link, rgbaColor=colour, physicsClientId=cid)
    return Multibody(body, goal)


def _visuals(pb: ModuleType, cid: int, chain: DiscreteBackbone) -> dict:
    """Visual shapes: per link ``(kind, index)`` (rod piece, rod with disk, tip), ``"base"``
    and ``"goal"``. The rod is drawn a little thicker than it is (≥ 3 mm radius) to be seen."""
    p = chain.params
    rod_r = max(0.5 * p.backbone_diameter, 0.003)

    def array(parts):
        return pb.createVisualShapeArray(
            shapeTypes=[k for k, _, _ in parts],
            radii=[r for _, r, _ in parts],
            lengths=[ln for _, _, (ln, _) in parts],
            visualFramePositions=[pos for _, _, (_, pos) in parts],
            physicsClientId=cid,
        )

    cyl, sph = pb.GEOM_CYLINDER, pb.GEOM_SPHERE
    half = chain.segment_lengths * 0.5
    n = chain.n_links
    cache: dict = {}
    out: dict = {}
    for j in range(n):
        kind = "tip" if j == n - 1 else ("disk" if (j + 1) % chain.links_per_span == 0 else "rod")
        a = float(half[j])
        length = a + (float(half[j + 1]) if j < n - 1 else 0.0)
        key = (kind, a, length)
        if key not in cache:
            rod = (cyl, rod_r, (length, (0.0, 0.0, 0.5 * length)))
            disk = (cyl, p.disk_radius, (p.disk_thickness, (0.0, 0.0, a)))
            if kind == "rod":
                parts = [rod]
            elif kind == "disk":
                parts = [rod, disk]
            else:
                holes = [
                    (sph, 0.004, (0.0, (float(x), float(y), a + 0.5 * p.disk_thickness)))
                    for x, y, _ in chain.disk_pinholes[-1][
                        np.asarray(p.cable_section) == p.n_sections - 1
                    ]
                ]
                parts = [rod, disk, *holes]
            cache[key] = array(parts)
        out[(kind, j)] = cache[key]
    base_rod = (cyl, rod_r, (float(half[0]), (0.0, 0.0, 0.5 * float(half[0]))))
    base_disk = (cyl, p.disk_radius, (p.disk_thickness, (0.0, 0.0, 0.0)))
    out["base"] = array([base_rod, base_disk])
    out["goal"] = pb.createVisualShape(
        sph, rgbaColor=(0.55, 0.1, 0.75, 1.0), radius=0.012, physicsClientId=cid
    )
    return out
