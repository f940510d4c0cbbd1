"""The MJCF model of the discretised backbone, built from :class:`~cdcr_gym.params.RobotParams`.

The robot is the rigid-link, elastic-joint chain of ``cdcr_gym.model.discrete``
(:class:`~cdcr_gym.model.discrete.DiscreteBackbone`: the same links, joint placement
half-way between the rod stations, masses and inertias), written as MuJoCo data:

Bodies and joints
    ``base`` (welded to the world) carries the base disk; ``link1`` … ``link{n}`` are nested,
    link j's frame at its joint with +z along the link. Each link holds its joint(s), an
    ``<inertial>`` from the chain model, a site ``station{j}`` at its rod station (the disk
    centre on a disk link; ``tip`` on the last link) and, on a disk link, one site per pinhole.
    ``joint="cardan"``: two hinges, about x then about the resulting y (R = Rx(a)·Ry(b), bullet's
    joint, no twist coordinate), each of stiffness EI/Δ. ``joint="ball"``: a MuJoCo ball joint,
    whose stiffness EI/Δ acts on the rotation vector (isotropic: the twist stiffness is EI/Δ
    too, where the rod's is GJ/Δ = EI/((1 + ν)Δ)); a bend in any plane adds no twist, unlike
    the Cardan pair's a·b/2 (``docs/mujoco_backend.md``). Stiffness and damping are MuJoCo joint
    attributes, integrated by MuJoCo (its Euler integrator treats the damping implicitly).

Cables: one spatial tendon per cable
    Cable i's tendon starts at its pinhole in the base disk and runs through the sites of every
    disk it passes to its anchor disk (its section's last disk). A motor actuator on it with
    ``gear = -1`` and ``ctrlrange = [0, max_tension]`` makes ``ctrl`` the cable tension: MuJoCo
    applies the generalized force −T·∂l/∂q (a positive tension shortens the cable), the
    frictionless cable's load. The tendon length is the sensed cable length.

Routing (``routing``)
    ``"disk"``: the tendon runs straight from pinhole to pinhole, bullet's model. With m =
    ``links_per_span`` links per span of length h, a joint at fraction u of a span sees the
    moment arm r + (h²κ/2)·u(1−u) + h²κ/(8m²); the rod it stands for (the Voronoi cell of width
    Δ = h/m around the joint) has the mean arm r + (h²κ/2)·(u(1−u) − 1/(12m²)). The excess,
    h²κ/(6m²), is the polygon vertex bulging out of the arc: 3× the physical discrete-routing
    effect at m = 1 (``docs/bullet_backend.md``). ``"corrected"`` (the default): each pinhole
    of an intermediate disk is replaced by two via-sites on the disk's link, at ∓b along the
    link from the disk centre (the base disk's at +b, the anchor disk's at −b, the anchor
    itself at the disk), with **b = Δ/(3m)**. The straight cable between via-sites of
    neighbouring disks then passes every joint of the span at exactly the rod's arm to first
    order in the joint angle (derivation in ``docs/mujoco_backend.md``); the piece between a
    disk's two via-sites is rigid. A straight robot's tendon lengths are the exact cable
    lengths either way, and a bent one's differ from the straight-chord lengths by O(h·α²).

Friction segments (``segment_tendons=True``)
    One more tendon per cable and disk span it crosses (the part of the cable tendon across that
    span) with a motor actuator of unlimited ``ctrl``: the backend loads segment k with the
    capstan tension minus the actuator's (``cdcr_gym.model.friction``), so that each segment
    carries its own tension.

Displacement drives (``drives=True``)
    One ``general`` actuator per cable tendon (``drive{i}``, after every motor) whose ``ctrl`` is
    the tendon displacement d (m) at the drive (SPEC §8): force
    ``gain·ctrl + bias = −k·d + (k·L0 − T0) − k·L`` clamped to ``forcerange = [−T_max, 0]``,
    i.e. a tension T = clip(T0 + k·(d − (L0 − L)), 0, T_max) along the tendon (the sign of the
    motors with ``gear = -1``; the one-sided clamp is the slack tendon, the other side
    saturation). L0 is the tendon's straight length, known only once the model is compiled:
    the backend writes ``biasprm[0] = k·L0 − T0`` then (the XML holds 0).

Obstacles (``obstacles`` > 0)
    Capsule geoms along the links (radius d/2) and a disk cylinder per disk, and ``obstacles``
    sphere geoms on mocap bodies (``obstacle0`` …: positions in ``MjData.mocap_pos``, per
    robot; radii in the model), parked far away until placed. Contacts are
    between robot and spheres only (``contype``/``conaffinity``). With ``solid_obstacles`` the
    contact and constraint stages run (penetrating contacts push back); without, they stay
    disabled and the backend measures clearances on demand (``mj_geomDistance``). Without
    obstacles the model has no collision geometry.

Frames: the MJCF world frame *is* the base frame R0 (backbone along +z, cable β = 0 at +x); a
turned base is modelled by turning gravity into R0 (``gravity``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from cdcr_gym.model.discrete import DiscreteBackbone
from cdcr_gym.model.params import RobotParams

__all__ = ["JOINTS", "PARKED", "MJCFModel", "build_mjcf"]

#: Joint types: a ball joint (rotation-vector stiffness), or bullet's two hinges.
JOINTS = ("ball", "cardan")
#: Where obstacles wait until they are placed (m, far outside any robot).
PARKED = 1.0e3


@dataclass(frozen=True)
class MJCFModel:
    """An MJCF document and the names the backend reads it by.

    Attributes:
        xml: the MJCF text.
        chain: the discretised backbone it was built from (geometry, masses, routing).
        n_links: links n (= Σ n_disks·m).
        dof_per_joint: degrees of freedom per joint, 2 (cardan) or 3 (ball).
        station_sites: site names of the stations 1..n (the last is ``"tip"``).
        disk_links: 1-based link index of every spacer disk (n_disks,).
        pinhole_sites: [disk k (0 = base)][cable i] site name of cable i's pinhole position on
            disk k (on every disk; the cable passes those up to its anchor).
        cable_paths: the site names of every cable's tendon, base to anchor.
        segment_tendons: [span k][cable i] tendon name (None where cable i does not cross span
            k, or when the model has no segment tendons).
        obstacles: number of obstacle sphere geoms.
    """

    xml: str
    chain: DiscreteBackbone
    n_links: int
    dof_per_joint: int
    station_sites: tuple[str, ...]
    disk_links: tuple[int, ...]
    pinhole_sites: tuple[tuple[str, ...], ...]
    cable_paths: tuple[tuple[str, ...], ...]
    segment_tendons: tuple[tuple[str | None, ...], ...]
    obstacles: int


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(values))


def build_mjcf(
    params: RobotParams,
    *,
    links_per_span: int = 1,
    joint: str = "ball",
    routing: str = "corrected",
    gravity: np.ndarray | tuple[float, float, float] = (0.0, 0.0, -9.81),
    tip_payload: float = 0.0,
    timestep: float = 0.01,
    damping: np.ndarray | float = 0.0,
    integrator: str = "Euler",
    segment_tendons: bool = False,
    obstacles: int = 0,
    solid_obstacles: bool = False,
    drives: bool = False,
) -> MJCFModel:
    """The MJCF model of ``params`` (module docstring).

    Args:
        params: the robot, any number of sections.
        links_per_span: rigid links per disk span, m >= 1.
        joint: ``"cardan"`` or ``"ball"`` (:data:`JOINTS`).
        routing: ``"corrected"`` or ``"disk"`` (:data:`ROUTINGS`).
        gravity: gravity (3,) m/s² in R0 (the world frame of the model).
        tip_payload: point mass (kg) at the tip disk centre.
        timestep: MuJoCo's physics timestep (s).
        damping: joint damping D (N·m·s/rad) per joint coordinate (n·dof_per_joint,) or the
            damping time β (s, a scalar: D = β·K).
        integrator: MuJoCo integrator name (``"Euler"``, ``"implicitfast"``, ``"RK4"``, ...).
        segment_tendons: add the per-span friction tendons and their actuators.
        obstacles: number of sphere obstacles (0: no collision geometry at all).
        solid_obstacles: whether contacts with the spheres push back (constraint stage on).
        drives: add the displacement drives (module docstring), stiffness
            ``params.cable_stiffness`` (finite), after every other actuator.

    The caller (``MuJoCoBackend``) validates the arguments.
    """
    chain = DiscreteBackbone(
        params, links_per_span, tip_payload, None, gravity=False, routing=routing
    )
    m = chain.links_per_span
    n = chain.n_links
    dof = 2 if joint == "cardan" else 3
    delta = chain.segment_lengths  # (n,) station spacing Δ_j
    half = 0.5 * delta
    lead = np.empty(n)  # joint j -> joint j+1 (the base: base -> joint 1)
    lead[0] = half[0]
    lead[1:] = half[:-1] + half[1:]
    ei = params.bending_stiffness
    stiffness = np.repeat((ei / delta)[:, None], dof, axis=1)
    damp = np.asarray(damping, dtype=np.float64)
    damp = damp * stiffness if damp.ndim == 0 else damp.reshape(n, dof)

    owner = np.asarray(params.cable_section)
    n_cables = params.n_cables
    disks = [s.n_disks for s in params.sections]
    n_disks = sum(disks)
    # the last disk (1-based) each cable reaches
    ends = np.cumsum(disks)
    anchor_disk = ends[owner]
    pin_local = chain.disk_pinholes  # (n_disks+1, C, 3): helical routing turns them
    rod_radius = 0.5 * params.backbone_diameter

    root = ET.Element("mujoco", model="cdcr")
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    option = ET.SubElement(
        root,
        "option",
        timestep=repr(float(timestep)),
        gravity=_fmt(gravity),
        integrator=integrator,
    )
    if obstacles == 0 or not solid_obstacles:
        ET.SubElement(option, "flag", contact="disable", constraint="disable")
    ET.SubElement(root, "size", memory="1M")
    world = ET.SubElement(root, "worldbody")
    base = ET.SubElement(world, "body", name="base", pos="0 0 0")
    pinhole_sites: list[list[str]] = [[""] * n_cables for _ in range(n_disks + 1)]
    # routing sites of every cable, in order along the cable: (site name, the span it begins)
    paths: list[list[str]] = [[] for _ in range(n_cables)]
    span_start: list[dict[int, int]] = [{} for _ in range(n_cables)]  # span -> index in path

    def add_pinholes(body: ET.Element, disk: int, z: float) -> None:
        b = float(chain.via_offsets[disk])  # the routing geometry: DiscreteBackbone's
        for i in range(n_cables):
            x, y = pin_local[disk, i, 0], pin_local[disk, i, 1]
            name = f"pin{disk}_{i}"
            ET.SubElement(body, "site", name=name, pos=_fmt((x, y, z)), size="0.002")
            pinhole_sites[disk][i] = name  # every disk: the geometry of the wrap angles
            if disk > anchor_disk[i]:
                continue
            last = disk == anchor_disk[i]
            if b == 0.0:
                paths[i].append(name)
            else:
                if disk > 0:  # arriving: the via-site before the disk (on a helix: its point there)
                    via = f"via{disk}_{i}_in"
                    vx, vy, _ = chain.via_points_in[disk - 1, i]
                    ET.SubElement(body, "site", name=via, pos=_fmt((vx, vy, z - b)), size="0.001")
                    paths[i].append(via)
                if disk == 0 or last:  # the base pinhole and the anchor are on the path
                    paths[i].append(name)
                if not last:  # leaving: the via-site after the disk
                    via = f"via{disk}_{i}_out"
                    vx, vy, _ = chain.via_points_out[disk, i]
                    ET.SubElement(body, "site", name=via, pos=_fmt((vx, vy, z + b)), size="0.001")
                    paths[i].append(via)
            if not last:
                span_start[i][disk] = len(paths[i]) - 1

    add_pinholes(base, 0, 0.0)
    # the base's half link is clamped; the obstacles' capsules start at the base disk
    if obstacles:
        ET.SubElement(
            base,
            "geom",
            type="capsule",
            fromto=_fmt((0, 0, 0, 0, 0, half[0])),
            size=repr(rod_radius),
            contype="1",
            conaffinity="0",
            mass="0",
        )
    parent = base
    station_sites = []
    disk_links = []
    for j in range(1, n + 1):
        body = ET.SubElement(parent, "body", name=f"link{j}", pos=_fmt((0.0, 0.0, lead[j - 1])))
        if joint == "ball":
            ET.SubElement(
                body,
                "joint",
                name=f"j{j}",
                type="ball",
                stiffness=repr(float(stiffness[j - 1, 0])),
                damping=repr(float(damp[j - 1, 0])),
                limited="false",
            )
        else:
            for a, axis in enumerate(("1 0 0", "0 1 0")):
                ET.SubElement(
                    body,
                    "joint",
                    name=f"j{j}_{'xy'[a]}",
                    type="hinge",
                    axis=axis,
                    stiffness=repr(float(stiffness[j - 1, a])),
                    damping=repr(float(damp[j - 1, a])),
                    limited="false",
                )
        ET.SubElement(
            body,
            "inertial",
            pos=_fmt((0.0, 0.0, chain.link_com_offsets[j - 1])),
            mass=repr(float(chain.link_masses[j - 1])),
            diaginertia=_fmt(chain.link_inertias[j - 1]),
        )
        z = float(half[j - 1])
        name = "tip" if j == n else f"station{j}"
        ET.SubElement(body, "site", name=name, pos=_fmt((0.0, 0.0, z)), size="0.003")
        station_sites.append(name)
        length = z + (float(half[j]) if j < n else 0.0)
        if obstacles:
            ET.SubElement(
                body,
                "geom",
                type="capsule",
                fromto=_fmt((0, 0, 0, 0, 0, length)),
                size=repr(rod_radius),
                contype="1",
                conaffinity="0",
                mass="0",
            )
        if j % m == 0:
            disk = j // m
            disk_links.append(j)
            add_pinholes(body, disk, z)
            if obstacles:
                ET.SubElement(
                    body,
                    "geom",
                    type="cylinder",
                    pos=_fmt((0.0, 0.0, z)),
                    size=_fmt((params.disk_radius, 0.5 * params.disk_thickness)),
                    contype="1",
                    conaffinity="0",
                    mass="0",
                )
        parent = body

    for k in range(obstacles):  # mocap bodies: their positions are per-data (per robot)
        holder = ET.SubElement(
            world,
            "body",
            name=f"obstacle{k}",
            mocap="true",
            pos=_fmt((PARKED * (k + 1), PARKED, PARKED)),
        )
        ET.SubElement(
            holder,
            "geom",
            name=f"obstacle{k}",
            type="sphere",
            size="0.01",
            contype="0",
            conaffinity="1",
            rgba="0.6 0.3 0.8 0.5",
        )

    tendon = ET.SubElement(root, "tendon")
    actuator = ET.SubElement(root, "actuator")
    for i in range(n_cables):
        spatial = ET.SubElement(tendon, "spatial", name=f"cable{i}", width="0.0005")
        for site in paths[i]:
            ET.SubElement(spatial, "site", site=site)
    for i in range(n_cables):
        ET.SubElement(
            actuator,
            "motor",
            name=f"pull{i}",
            tendon=f"cable{i}",
            gear="-1",
            ctrlrange=_fmt((0.0, params.max_tension)),
        )
    segments: list[list[str | None]] = [[None] * n_cables for _ in range(n_disks)]
    if segment_tendons:
        for i in range(n_cables):
            for k in range(int(anchor_disk[i])):
                # the segment across span k: from the last site of disk k to the next one
                start = span_start[i][k]
                first, second = paths[i][start], paths[i][start + 1]
                name = f"seg{k}_{i}"
                spatial = ET.SubElement(tendon, "spatial", name=name, width="0.0005")
                ET.SubElement(spatial, "site", site=first)
                ET.SubElement(spatial, "site", site=second)
                segments[k][i] = name
                ET.SubElement(
                    actuator,
                    "motor",
                    name=f"fric{k}_{i}",
                    tendon=name,
                    gear="-1",
                    ctrllimited="false",
                )
    if drives:
        for i, stiff in enumerate(params.cable_stiffness):
            ET.SubElement(
                actuator,
                "general",
                name=f"drive{i}",
                tendon=f"cable{i}",
                gaintype="fixed",
                gainprm=_fmt(-stiff),
                biastype="affine",
                biasprm=_fmt((0.0, -stiff, 0.0)),
                ctrllimited="false",
                forcelimited="true",
                forcerange=_fmt((-params.max_tension, 0.0)),
            )
    return MJCFModel(
        xml=ET.tostring(root, encoding="unicode"),
        chain=chain,
        n_links=n,
        dof_per_joint=dof,
        station_sites=tuple(station_sites),
        disk_links=tuple(disk_links),
        pinhole_sites=tuple(tuple(row) for row in pinhole_sites),
        cable_paths=tuple(tuple(path) for path in paths),
        segment_tendons=tuple(tuple(row) for row in segments),
        obstacles=obstacles,
    )
