"""The discretised backbone shared by the physics backends, as pure numpy (no simulator).

``cdcr_gym.backends.bullet.BulletBackend`` simulates this model's dynamics in pybullet and
``cdcr_gym.backends.mujoco.MuJoCoBackend`` builds its MJCF from it; this module holds its
geometry, mass properties, cable routing, cable and gravity loads, statics and the span-buckling
bound, so that they are written once, can be checked against both simulators (tests), and can be
evaluated for chains longer than one pybullet multibody can hold (pybullet's API keeps 121 joint
coordinates per body: 60 Cardan joints).

Discretisation and joint placement
    The backbone carries a fixed base disk at s = 0 and, section after section, each section's
    ``n_disks`` spacer disks evenly over its length ℓ_j (disk span h_j = ℓ_j/n_disks_j, the
    section's last disk at its end, the robot's last disk at the tip). Each disk span is cut
    into ``links_per_span`` = m pieces of length Δ = h_j/m, giving n = m·Σ_j n_disks_j *rod
    stations* s_0 = 0 < s_1 < … < s_n = ℓ (every m-th carries a disk; the spacing Δ_j of the
    interval (s_{j−1}, s_j] is its section's). The joints sit **half-way between stations**,
    at s_{j−1} + Δ_j/2, j = 1..n; rigid link j runs from joint j to joint j+1 and carries
    station j (Δ_j/2 from its joint: the link's centre inside a section, off-centre only on the
    link that crosses from one section's spacing to the next). The base holds the half link
    [0, Δ_1/2] (clamped); the tip link is the half link [ℓ − Δ_n/2, ℓ] with the tip disk at its
    end. Why this placement (a staggered grid):

    * every disk sits in the middle of a straight link, so on a bent backbone it lies on the arc
      and is normal to the arc's tangent there, to O(α²) (α = κΔs, the joint angle); joints at
      the disks would tilt each disk by α/2 (first order);
    * every joint's share of the rod (its Voronoi cell, station j−1 to station j) is exactly
      Δ_j, the end joints included, so joint j has the stiffness EI/Δ_j, and a pure moment M
      bends the chain through exactly θ = M·ℓ/EI for any n;
    * a joint never coincides with a pinhole, so exactly one straight segment of each cable
      crosses each joint, and its generalized force is one cross product (below);
    * convergence: with the cable straight between pinholes, a joint at fraction u of a disk span
      sees the moment arm r + (h²κ/2)·u(1−u) + h²κ/(8m²) (the arc's sagitta, plus the polygon
      vertex's excess over the arc). Averaged over the m joints of a span this is
      r + (h²κ/12)·(1 + 2/m²). So as m → ∞ the model converges, at O(1/m²), to a continuous rod
      between discrete disks (span-mean arm r + h²κ/12: the physical discrete-routing effect),
      and as n_disks → ∞ (h → 0) to the elastica θ = T·r·ℓ/EI. With m = 1 the discrete-routing
      excess is 3× the physical one; joints at the disks would give the factor (1 − 1/m²)
      instead, i.e. no discrete-routing effect at all at m = 1, plus the disk tilt above.

2-DOF joints without twist or extension
    Each joint is a Cardan (universal) joint: a rotation a_j about the parent link's X axis,
    then b_j about the resulting Y axis, R = Rx(a)·Ry(b). It has no twist and no extension
    degree of freedom. The generalized coordinates q = [a_1, b_1, a_2, b_2, …] are plain angles,
    so the joint stiffness is diagonal, K = EI/Δs·I (strain energy (EI/2Δs)·(a² + b²), exact
    to fourth order in the joint angle), and every Jacobian column is a single cross product.

Cable routing (n sections)
    A cable of section j has one pinhole in every disk of sections 1..j, at (r, β + p·z_k) in
    the frame of disk k at arc length z_k (p the robot's ``cable_pitch``: 0, the same pinhole
    on every disk, unless the cables wind helically), and is anchored at section j's last
    disk: it runs straight from pinhole to pinhole across every disk span of sections 1..j and
    crosses no span beyond. The spans it crosses are :attr:`DiscreteBackbone.routed`
    ((n_disks, C) bool).

    Two routings (``routing``), one geometry for both backends (the MuJoCo backend's MJCF takes
    its via-sites from :attr:`DiscreteBackbone.via_offsets`):

    * ``"disk"``: the cable runs straight from pinhole to pinhole. With m links per span the
      span-mean moment arm is r + (h²κ/12)·(1 + 2/m²) (above, "Discretisation"): at m = 1 the
      discrete-routing effect is 3× the physical one, and the chain bends too far (5 % of ℓ on
      the paper robot against the converged Cosserat rod).
    * ``"corrected"``: every pinhole of an intermediate disk is replaced by two via-points on the
      disk's link, at ∓b along the link from the disk centre (the base disk's at +b, the anchor
      disk's at −b, the cable anchored at the disk itself), **b = Δ/(3m)** (:func:`via_offset`;
      a disk takes the Δ of the span arriving at it, the base disk the first span's). The
      straight cable between the via-points of neighbouring disks then passes every joint of
      the span at the rod's mean arm to first order in the joint angle, which cancels the
      polygon's excess h²κ/(6m²); the pieces between a disk's via-points are rigid
      (:attr:`DiscreteBackbone.rigid_lengths`). A straight robot's cable lengths are exact
      either way. With ``"disk"`` every b is 0 and the code paths are the plain pinhole ones
      (bit-identical to the model without via-points).

Cable loads
    Cable i is frictionless and anchored at its section's last disk: its tension T_i is uniform
    and its potential is T_i·l_i(q), l_i the sum of its straight segment lengths over the spans
    it crosses (pinhole to pinhole, or via-point to via-point; below, p_k and p_{k+1} are the
    segment's ends).
    The generalized forces are τ = −Σ_i T_i ∂l_i/∂q. For joint j (point o, axis a) inside disk
    span k, only the segment p_k → p_{k+1} of cable i (if it crosses span k) depends on q_j (the joints proximal to
    both pinholes move them rigidly together); with u its unit vector,
    ∂l_i/∂q_j = u·(a × (p_{k+1} − o)) = a·((p_{k+1} − o) × u), hence
    τ_j = −Σ_i T_i·a·((p_{k+1,i} − o) × u_{k,i}) = a·(o × F_k − G_k),
    F_k = Σ_i T_i u_{k,i},  G_k = Σ_i T_i p_{k+1,i} × u_{k,i}  (sums over the cables crossing k).
    These are exactly the generalized forces of the point forces ∓T_i·u at the two pinholes of
    every segment (on joints proximal to both pinholes the pair cancels: collinear forces).

Masses (the paper gives none; see ``RobotParams``)
    Rod: linear density ``backbone_linear_density`` (solid cylinder of diameter d). Disks: solid
    disks of ``disk_mass``, ``disk_radius``, ``disk_thickness`` (pinholes and bore neglected).
    Each link carries its rod piece, its disk (if its station carries one; all disks alike) and,
    at the tip,
    ``tip_payload`` as a point mass. The base's half link and the base disk are clamped.

Span buckling (the valid tension range)
    Between two disks the cables crossing a span are straight and pull the two disks together
    with P = Σ T_i: the span is a column under that load, and above a critical load the
    straight backbone is unstable. For the real rod that load is Euler's π²·EI/h_j² (pinned
    ends). The model's span is m links with joints of stiffness EI/Δ (Δ = h/m), whose straight
    pose loses stability at the discrete column's load
    P_cr = (4·EI/Δ²)·sin²(π/(2m))  (m = 1: 4·EI/h²; m = 2: 8·EI/h²; → π²·EI/h² as m → ∞),
    the zero of the smallest eigenvalue of the tangent stiffness K − ∂τ_cable/∂q at q = 0
    (``python -m experiments.verification --buckling`` compares the two). Beyond it the chain
    buckles (the paper's robot with 3 disks and one link per span, P_cr = 3 × 44 N, diverged
    after ≈ 1.7 s holding 80/80/80 N). :func:`check_span_buckling` rejects robots whose cables,
    all at ``max_tension``, reach P_cr in some span; as P_cr ≤ π²·EI/h², every accepted robot
    is also below the real rod's Euler load.

Frames: R0 at the base disk centre, backbone along +Z0, cable 1 at +X0; ``base_rotation`` maps
R0 to the world frame, where gravity is −9.81 m/s² along −Z_world. Positions here are world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams

__all__ = [
    "DiscreteBackbone",
    "ChainPose",
    "quat_to_matrix",
    "span_buckling_loads",
    "check_span_buckling",
    "bending_modes",
    "ROUTINGS",
    "via_offset",
]

_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


#: Cable routings (module docstring, "Cable routing").
ROUTINGS = ("corrected", "disk")


def via_offset(spacing: float, links_per_span: int, routing: str) -> float:
    """Offset b (m) of a disk's via-points from its centre along its link: Δ/(3m) with Δ =
    ``spacing``/m (``spacing`` the disk span h, m; m = ``links_per_span``) for
    ``"corrected"`` routing, 0 for ``"disk"`` (module docstring, "Cable routing")."""
    if routing == "disk":
        return 0.0
    m = links_per_span
    return spacing / m / (3.0 * m)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (one einsum: faster than np.cross for small arrays)."""
    return np.einsum("ijk,...j,...k->...i", _LEVI_CIVITA, a, b)


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from unit quaternions (..., 4) in pybullet's (x, y, z, w)."""
    quat = np.asarray(quat, dtype=np.float64)
    x, y, z, w = quat[..., 0], quat[..., 1], quat[..., 2], quat[..., 3]
    rot = np.empty(quat.shape[:-1] + (3, 3))
    rot[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    rot[..., 0, 1] = 2.0 * (x * y - w * z)
    rot[..., 0, 2] = 2.0 * (x * z + w * y)
    rot[..., 1, 0] = 2.0 * (x * y + w * z)
    rot[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    rot[..., 1, 2] = 2.0 * (y * z - w * x)
    rot[..., 2, 0] = 2.0 * (x * z - w * y)
    rot[..., 2, 1] = 2.0 * (y * z + w * x)
    rot[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return rot


def _cardan(ca: np.ndarray, sa: np.ndarray, cb: np.ndarray, sb: np.ndarray) -> np.ndarray:
    """Rx(a)·Ry(b), shape (k, 3, 3), from the cosines and sines (each shape (k,))."""
    rot = np.empty((ca.shape[0], 9))
    rot[:, 0] = cb
    rot[:, 1] = 0.0
    rot[:, 2] = sb
    rot[:, 3] = sa * sb
    rot[:, 4] = ca
    rot[:, 5] = -sa * cb
    rot[:, 6] = -ca * sb
    rot[:, 7] = sa
    rot[:, 8] = ca * cb
    return rot.reshape(-1, 3, 3)


def span_buckling_loads(
    params: RobotParams, links_per_span: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Per section: the critical load of one disk span and the cables' load on it, (S,) N each.

    The critical load is the model's P_cr = (4·EI/Δ²)·sin²(π/(2m)) with Δ = h_j/m (m =
    ``links_per_span``), ≤ Euler's π²·EI/h_j²; the load is the number of cables crossing
    section j's spans (its own and every distal section's) times ``max_tension`` (module
    docstring, "Span buckling").
    """
    m = links_per_span
    owner = np.asarray(params.cable_section)
    critical = np.array(
        [
            4.0
            * params.bending_stiffness
            / (s.disk_spacing / m) ** 2
            * math.sin(0.5 * math.pi / m) ** 2
            for s in params.sections
        ]
    )
    load = np.array(
        [np.count_nonzero(owner >= j) * params.max_tension for j in range(params.n_sections)]
    )
    return critical, load


def check_span_buckling(params: RobotParams, links_per_span: int = 1) -> None:
    """Reject a robot whose disk spans buckle with every cable at ``max_tension``.

    Raises:
        ValueError: naming ``params``, the section, both loads and the ways out.
    """
    critical, load = span_buckling_loads(params, links_per_span)
    for j, (crit, pull) in enumerate(zip(critical, load)):
        if not pull < crit:
            s = params.sections[j]
            n_min = math.floor(s.n_disks * math.sqrt(pull / crit)) + 1  # crit ∝ n_disks²
            euler = math.pi**2 * params.bending_stiffness / s.disk_spacing**2
            raise ValueError(
                f"params.sections[{j}] (n_disks={s.n_disks}, span {s.disk_spacing * 1e3:.1f} mm) "
                f"buckles between its disks: its cables at max_tension={params.max_tension:g} N "
                f"compress each span with {pull:.0f} N, at or above the critical load of one "
                f"span, {crit:.0f} N with links_per_span={links_per_span} (the straight span is "
                f"a column; Euler's π²·EI/h² = {euler:.0f} N for the real rod), and the "
                f"simulation would diverge. Use n_disks >= {n_min} for that section or "
                f"max_tension < {crit / (pull / params.max_tension):.1f} N"
                + (" or more links_per_span" if pull < euler else "")
            )


@dataclass(frozen=True)
class ChainPose:
    """World-frame geometry of the chain at one set of joint angles (all lengths in m).

    Attributes:
        joint_points: (n, 3) joint centres o_j.
        joint_axes: (n, 2, 3) unit axes of the X and the Y revolute of each joint.
        link_rot: (n, 3, 3) orientation of link j (its third column is the link direction).
        stations: (n+1, 3) rod stations s_j (0: base disk centre, n: tip disk centre).
        pinholes: (n_disks+1, C, 3) where every cable's pinhole sits on every disk
            [disk (base first), cable, xyz] (a cable passes only the disks of its own and the
            proximal sections: :attr:`DiscreteBackbone.routed`).
        coms: (n, 3) link centres of mass.
    """

    joint_points: np.ndarray
    joint_axes: np.ndarray
    link_rot: np.ndarray
    stations: np.ndarray
    pinholes: np.ndarray
    coms: np.ndarray


class DiscreteBackbone:
    """The rigid-link, elastic-joint model of the backbone (see the module docstring).

    Args:
        params: the robot.
        links_per_span: rigid links per disk span, m >= 1.
        tip_payload: point mass at the tip disk centre (kg, >= 0).
        base_rotation: (3, 3) rotation of R0 in the world (default identity: upright).
        gravity: whether :meth:`gravity_loads` returns the loads of −9.81 m/s² along −Z_world
            (``False``: zeros).
        routing: ``"disk"`` (the cable straight from pinhole to pinhole) or ``"corrected"``
            (via-points ∓Δ/(3m) along each disk's link; module docstring, "Cable routing").

    The caller (``BulletBackend``) validates the arguments; this class trusts them.
    """

    def __init__(
        self,
        params: RobotParams,
        links_per_span: int = 1,
        tip_payload: float = 0.0,
        base_rotation: np.ndarray | None = None,
        gravity: bool = True,
        routing: str = "disk",
    ) -> None:
        self.params = params
        self.routing = routing
        self.links_per_span = m = int(links_per_span)
        self.tip_payload = float(tip_payload)
        self.base_rotation = (
            np.eye(3) if base_rotation is None else np.asarray(base_rotation, float)
        )
        self.gravity = bool(gravity)
        disks = [s.n_disks for s in params.sections]
        #: Spacer disks of the whole robot (= disk spans), links n and joint coordinates 2n.
        self.n_disks = sum(disks)
        self.n_links = self.n_disks * m
        self.n_dof = 2 * self.n_links
        #: Section (0-based) of every disk span, (n_disks,).
        self.span_section = np.repeat(np.arange(params.n_sections), disks)
        #: Station spacing Δ_j = h/m of the interval ending at station j, per link (n_links,) m.
        self.segment_lengths = np.repeat(
            [s.length / (s.n_disks * m) for s in params.sections], [d * m for d in disks]
        )
        half = 0.5 * self.segment_lengths
        #: Distance from joint j to joint j+1 (the base: to joint 1), (n_links,) m.
        self._lead = np.empty(self.n_links)
        self._lead[0] = self.segment_lengths[0]
        self._lead[1:] = half[:-1] + half[1:]
        self._half = half
        #: Joint stiffness EI/Δ_j (N·m/rad) of every joint coordinate, (2n,): [a_1, b_1, ...].
        self.stiffness = np.repeat(params.bending_stiffness / self.segment_lengths, 2)
        beta = params.cable_angles_at_disks()  # (n_disks+1, C): β_i + pitch·z_k
        radius = np.asarray(params.cable_radii)
        #: Pinhole positions of every cable on every disk in that disk's frame, shape
        #: (n_disks+1, C cables, 3) m [disk (base first), cable, xyz]: the same on every disk
        #: for cables parallel to the backbone, turning by the pitch along a helical one.
        self.disk_pinholes = radius[None, :, None] * np.stack(
            [np.cos(beta), np.sin(beta), np.zeros(beta.shape)], axis=-1
        )
        #: Whether the pinholes differ from disk to disk (``RobotParams.cable_pitch`` != 0).
        self.helical = params.cable_pitch != 0.0
        #: Whether cable i crosses disk span k (is routed through its pinholes), (n_disks, C).
        self.routed = self.span_section[:, None] <= np.asarray(params.cable_section)[None, :]
        self._routed_f = self.routed.astype(np.float64)
        #: Via-point offset b_k (m) of every disk k = 0..n_disks along its link (0 for
        #: ``"disk"`` routing): the base disk's and disk k's use the spacing of the span that
        #: arrives at it (the base: the first span's).
        self.via_offsets = np.array(
            [
                via_offset(params.sections[int(j)].disk_spacing, m, routing)
                for j in (self.span_section[0], *self.span_section)
            ]
        )
        self._corrected = bool(np.any(self.via_offsets != 0.0))
        b = self.via_offsets
        #: Per cable (C,), m: the rigid pieces of its path on the disks (b on the base disk,
        #: 2·b_k on every disk it passes, b on its anchor): the path length is its straight
        #: segments across the spans plus this.
        self.rigid_lengths = ((b[:-1] + b[1:])[:, None] * self._routed_f).sum(axis=0)
        #: The via-points of every span k [span, cable, xyz] m: leaving disk k (pinhole +
        #: b_k·z, in disk k's frame) and arriving at disk k+1 (pinhole − b_{k+1}·z, in its
        #: frame), (n_disks, C, 3); on a helix where it passes them, at β + p·(z_k ± b_k).
        arc = params.disk_arc_positions()
        self.via_points_out = self._helix_points(params, arc[:-1] + b[:-1], b[:-1])
        self.via_points_in = self._helix_points(params, arc[1:] - b[1:], -b[1:])
        self._all_routed = bool(self.routed.all())
        self._base_pinholes = self.disk_pinholes[0] @ self.base_rotation.T
        # per section: (its first span, its last span + 1, the cables crossing it, the map of
        # _cable_loads_one_link for those cables and its spacing)
        owner = np.asarray(params.cable_section)
        ends = np.cumsum([0, *disks])
        self._sections = []
        for j in range(params.n_sections):
            first, stop = int(ends[j]), int(ends[j + 1])
            cables = slice(int(np.argmax(owner >= j)), params.n_cables)  # sections j.. (contiguous)
            half_h = 0.5 * params.sections[j].disk_spacing
            through = owner >= j
            if self.helical:  # every span its own map: its two disks' pinholes differ
                for a in range(first, stop):
                    link_map = self._build_one_link_map(
                        self.via_points_out[a, through] - [0.0, 0.0, b[a]],
                        half_h,
                        b[a],
                        b[a + 1],
                        self.via_points_in[a, through] + [0.0, 0.0, b[a + 1]],
                    )
                    self._sections.append((a, a + 1, cables, link_map))
                continue
            pins = self.disk_pinholes[0, through]
            # a section's spans share one map, but for the first when its proximal disk (the
            # previous section's last) has another via offset
            pieces = [first] if b[first] == b[first + 1] else [first, first + 1]
            for a, z in zip(pieces, [*pieces[1:], stop]):
                if a < z:
                    link_map = self._build_one_link_map(pins, half_h, b[a], b[a + 1])
                    self._sections.append((a, z, cables, link_map))
        props = [self._link_properties(j) for j in range(1, self.n_links + 1)]
        #: Link masses (n,) kg, COM offsets along the link from its joint (n,) m, and principal
        #: inertias about the COM (n, 3) kg·m² (Ixx = Iyy, Izz about the link axis).
        self.link_masses = np.array([pr[0] for pr in props])
        self.link_com_offsets = np.array([pr[1] for pr in props])
        self.link_inertias = np.array([pr[2] for pr in props])
        g = np.array([0.0, 0.0, -STANDARD_GRAVITY]) if self.gravity else np.zeros(3)
        self._weights = self.link_masses[:, None] * g  # (n, 3) N

    @staticmethod
    def _helix_points(params: RobotParams, z: np.ndarray, height: np.ndarray) -> np.ndarray:
        """Points (len(z), C, 3) m of every cable at arc lengths ``z`` (m) of its helix
        (β + p·z; parallel cables: their pinhole), ``height`` (len(z),) m along the disk's axis
        in the frame of the disk they belong to."""
        beta = np.asarray(params.cable_angles)[None, :] + params.cable_pitch * z[:, None]
        r = np.asarray(params.cable_radii)[None, :]
        h = np.broadcast_to(np.asarray(height, dtype=np.float64)[:, None], beta.shape)
        return np.stack([r * np.cos(beta), r * np.sin(beta), h], axis=-1)

    def _link_properties(self, j: int) -> tuple[float, float, tuple[float, float, float]]:
        """Mass (kg), COM offset along the link from its joint (m), principal inertias (kg·m²).

        Link j (1-based) starts at its joint (z = 0) and runs along +z to the next joint,
        Δ_j/2 + Δ_{j+1}/2 long (the tip link Δ_n/2); its station (and its disk, if any) is at
        z = Δ_j/2.
        """
        p = self.params
        station = float(self._half[j - 1])
        length = station + (float(self._half[j]) if j < self.n_links else 0.0)
        a = 0.5 * p.backbone_diameter
        m_rod = p.backbone_linear_density * length
        parts = [(m_rod, 0.5 * length, m_rod * (3 * a * a + length**2) / 12.0, 0.5 * m_rod * a * a)]
        if j % self.links_per_span == 0:
            md, rd, t = p.disk_mass, p.disk_radius, p.disk_thickness
            parts.append((md, station, md * (3 * rd * rd + t * t) / 12.0, 0.5 * md * rd * rd))
        if j == self.n_links and self.tip_payload > 0.0:
            parts.append((self.tip_payload, station, 0.0, 0.0))
        mass = sum(pt[0] for pt in parts)
        z_c = sum(pt[0] * pt[1] for pt in parts) / mass
        ixx = sum(pt[2] + pt[0] * (pt[1] - z_c) ** 2 for pt in parts)
        izz = sum(pt[3] for pt in parts)
        return mass, z_c, (ixx, ixx, izz)

    # ------------------------------------------------------------------ kinematics

    def pose(self, q: np.ndarray) -> ChainPose:
        """World geometry at joint angles ``q`` (2n,) rad (forward kinematics, float64).

        Link j's orientation is R_j = R_base·Rx(a_1)·Ry(b_1)·…·Rx(a_j)·Ry(b_j); joint 1 sits
        Δ_1/2 above the base, joint j+1 (Δ_j + Δ_{j+1})/2 along link j, station j Δ_j/2 along
        link j. :meth:`stations_and_pinholes` gives the same stations and pinholes (same bits)
        without the joint axes and COMs.
        """
        c, s = np.cos(q), np.sin(q)
        ca, sa = c[0::2], s[0::2]
        rot = self._orientations(ca, sa, c[1::2], s[1::2])
        prev, link_rot = rot[:-1], rot[1:]  # parent orientation of joint j, orientation of link j
        axes = np.empty((self.n_links, 2, 3))
        axes[:, 0] = prev[:, :, 0]  # X revolute: the parent's X axis
        # Y revolute: the intermediate frame's Y axis, parent·Rx(a)·e_y = parent·(0, cos a, sin a)
        axes[:, 1] = prev[:, :, 1] * ca[:, None] + prev[:, :, 2] * sa[:, None]
        tangent = rot[:, :, 2]  # (n+1, 3): base and link directions
        joint_points, stations = self._joint_points_and_stations(tangent)
        pins = self._pinholes(rot, stations)
        coms = joint_points + self.link_com_offsets[:, None] * tangent[1:]
        return ChainPose(joint_points, axes, link_rot, stations, pins, coms)

    def stations_and_pinholes(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The readings-only part of :meth:`pose`: stations (n+1, 3) and pinholes (n_disks+1, C, 3), m.

        World frame, bit-identical to ``pose(q).stations`` and ``pose(q).pinholes``; skips the
        joint axes and link COMs, which the tip and the sensed cable lengths do not need
        (what the env's observation reads every step).
        """
        c, s = np.cos(q), np.sin(q)
        rot = self._orientations(c[0::2], s[0::2], c[1::2], s[1::2])
        stations = self._joint_points_and_stations(rot[:, :, 2])[1]
        return stations, self._pinholes(rot, stations)

    def _orientations(self, ca, sa, cb, sb) -> np.ndarray:
        """R_base and the link orientations R_1..R_n, shape (n+1, 3, 3), from the joints'
        cosines and sines (each (n,)).

        The prefix products use a log-depth (Hillis–Steele) scan: ⌈log2(n+1)⌉ batched matmuls
        instead of n small ones.
        """
        n = self.n_links
        rot = np.empty((n + 1, 3, 3))
        rot[0] = self.base_rotation
        rot[1:] = _cardan(ca, sa, cb, sb)
        d = 1
        while d <= n:
            rot[d:] = np.matmul(rot[:-d], rot[d:])
            d *= 2
        return rot

    def _joint_points_and_stations(self, tangent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint centres (n, 3) and rod stations (n+1, 3), m, from the base and link directions
        ``tangent`` (n+1, 3) (the third columns of :meth:`_orientations`)."""
        joint_points = np.cumsum(tangent[:-1] * self._lead[:, None], axis=0)
        joint_points -= self._half[0] * tangent[0]
        stations = np.empty((self.n_links + 1, 3))
        stations[0] = 0.0
        stations[1:] = joint_points + self._half[:, None] * tangent[1:]
        return joint_points, stations

    def _pinholes(self, rot: np.ndarray, stations: np.ndarray) -> np.ndarray:
        """Pinholes (n_disks+1, C, 3) [disk (base first), cable, xyz], m, from the orientations
        (n+1, 3, 3) and stations (n+1, 3): disk k sits at station k·m, on link k·m."""
        m = self.links_per_span
        pins = np.empty(self.disk_pinholes.shape)
        pins[0] = self._base_pinholes
        local = self.disk_pinholes[1:] if self.helical else self.disk_pinholes[0]
        pins[1:] = stations[m::m][:, None, :] + np.matmul(local, rot[m::m].transpose(0, 2, 1))
        return pins

    def cable_lengths(self, q: np.ndarray) -> np.ndarray:
        """Cable path lengths (C,) m at joint angles ``q`` (2n,) rad (:meth:`lengths_of_pose`)."""
        return self.lengths_of_pose(self.pose(q))

    def lengths_of_pose(self, pose: ChainPose) -> np.ndarray:
        """Cable path lengths (C,) m of a :meth:`pose`: with ``"disk"`` routing
        :meth:`lengths_between_pinholes`; with ``"corrected"`` the straight segments between the
        via-points of neighbouring disks (:meth:`span_cable_lengths`) plus
        :attr:`rigid_lengths` (a straight robot's lengths are the exact cable lengths either
        way)."""
        if not self._corrected:
            return self.lengths_between_pinholes(pose.pinholes)
        return self._span_lengths(pose).sum(axis=0) + self.rigid_lengths

    def span_cable_lengths(self, q: np.ndarray) -> np.ndarray:
        """Length (n_disks, C) m of every cable's straight segment across every disk span
        [span, cable] at joint angles ``q`` (2n,) rad (0 where the cable does not cross the
        span): pinhole to pinhole, or via-point to via-point with ``"corrected"`` routing."""
        return self._span_lengths(self.pose(q))

    def _span_lengths(self, pose: ChainPose) -> np.ndarray:
        """:meth:`span_cable_lengths` of a pose: the via-points are the pinholes ± b_k along
        the disks' axes, so segment k is p_{k+1} − p_k − (b_k·z_k + b_{k+1}·z_{k+1})."""
        m = self.links_per_span
        axis = np.empty((self.n_disks + 1, 3))  # base, then the disk links' z axes
        axis[0] = self.base_rotation[:, 2]
        axis[1:] = pose.link_rot[m - 1 :: m, :, 2]
        shift = axis * self.via_offsets[:, None]
        pins = pose.pinholes
        seg = pins[1:] - pins[:-1] - (shift[:-1] + shift[1:])[:, None, :]
        return np.sqrt((seg * seg).sum(axis=-1)) * self._routed_f

    def lengths_between_pinholes(self, pinholes: np.ndarray) -> np.ndarray:
        """Cable lengths (C,) m from pinholes (n_disks+1, C, 3): each cable's segment lengths
        summed over the spans it crosses (base disk to its section's last disk)."""
        seg = pinholes[1:] - pinholes[:-1]
        seg_len = np.sqrt((seg * seg).sum(axis=-1))
        return (seg_len if self._all_routed else seg_len * self._routed_f).sum(axis=0)

    # ------------------------------------------------------------------ loads

    def cable_loads(self, q: np.ndarray, tensions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Generalized cable forces τ = −Σ_i T_i ∂l_i/∂q (2n,) N·m and cable lengths (C,) m.

        ``tensions`` (C,) N, in cable order (section by section), or per disk span
        (n_disks, C) N (a cable with friction: segment k's tension in row k). A segment's length
        depends only on its own span's joints, so per-segment tensions enter span by span.

        Evaluated span by span in the frame of the span's proximal disk (generalized forces and
        segment lengths are frame-invariant), so no global forward kinematics is needed: the
        segment of cable i across disk span k runs from the pinhole p_a, fixed in the proximal
        disk's frame, to p_b on the distal disk, which only the span's m joints move. Then
        τ_j = a·(o × F − G) (module docstring). Vectorised over the spans, a loop over the m
        joints of a span. Used every physics step.
        """
        if self.links_per_span == 1:
            return self._cable_loads_one_link(q, tensions)
        return self._cable_loads_spans(q, tensions)

    def _cable_loads_spans(
        self, q: np.ndarray, tensions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`cable_loads` for any number of links per span."""
        n_span, m = self.n_disks, self.links_per_span
        half = self._half[::m, None]  # Δ/2 of every span's links, (n_span, 1)
        c, s = np.cos(q).reshape(n_span, m, 2), np.sin(q).reshape(n_span, m, 2)
        points = np.empty((n_span, m, 3))  # joint points in the span frame
        axes = np.empty((n_span, m, 2, 3))  # their X and Y revolute axes
        rot = pos = np.empty(0)
        for i in range(m):
            ca, sa = c[:, i, 0], s[:, i, 0]
            local = _cardan(ca, sa, c[:, i, 1], s[:, i, 1])
            if i == 0:  # the span frame itself; the joint Δ/2 up its axis
                points[:, 0, :2] = 0.0
                points[:, 0, 2] = half[:, 0]
                axes[:, 0, 0] = (1.0, 0.0, 0.0)
                axes[:, 0, 1, 0] = 0.0
                axes[:, 0, 1, 1] = ca
                axes[:, 0, 1, 2] = sa
                rot = local
            else:
                points[:, i] = pos + half * rot[:, :, 2]
                axes[:, i, 0] = rot[:, :, 0]
                axes[:, i, 1] = rot[:, :, 1] * ca[:, None] + rot[:, :, 2] * sa[:, None]
                rot = np.matmul(rot, local)
            pos = points[:, i] + half * rot[:, :, 2]  # the next station
        if self._corrected:  # via-points ∓b along the disks' links
            p_b = pos[:, None, :] + np.matmul(self.via_points_in, rot.transpose(0, 2, 1))
            seg = p_b - self.via_points_out  # (n_span, C cables, 3)
        else:
            # parallel cables: one pinhole set for every disk, broadcast (as before the helix)
            flat = not self.helical
            distal = self.disk_pinholes[0] if flat else self.disk_pinholes[1:]
            proximal = self.disk_pinholes[0] if flat else self.disk_pinholes[:-1]
            p_b = pos[:, None, :] + np.matmul(distal, rot.transpose(0, 2, 1))
            seg = p_b - proximal  # (n_span, C cables, 3)
        seg_len = np.sqrt((seg * seg).sum(axis=-1))  # (n_span, C)
        tu = seg * (tensions * self._routed_f / seg_len)[..., None]  # T_i·u_i, 0 if not routed
        force = tu.sum(axis=1)  # F (n_span, 3)
        couple = _cross(p_b, tu).sum(axis=1)  # G (n_span, 3)
        moment = _cross(points, force[:, None, :]) - couple[:, None, :]  # (n_span, m, 3)
        tau = (axes * moment[:, :, None, :]).sum(axis=-1).reshape(-1)
        lengths = (seg_len * self._routed_f).sum(axis=0)
        return tau, (lengths + self.rigid_lengths if self._corrected else lengths)

    def _cable_loads_one_link(
        self, q: np.ndarray, tensions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`cable_loads` for one link per span (the default), in a handful of numpy calls.

        Each span has one joint, at o = (0, 0, h/2) in the span frame, turning the link by
        R = Rx(a)·Ry(b) with columns X = (cos b, sin a·sin b, −cos a·sin b), Y = (0, cos a, sin a),
        Z = (sin b, −sin a·cos b, cos a·cos b). Cable i runs from its pinhole p_i = (x_i, y_i, 0)
        on the proximal disk to o + (h/2)·Z + x_i·X + y_i·Y on the distal one: segment d_i.
        Its pull on the distal disk, −T_i·d_i/|d_i|, has the moment M_i = (T_i/|d_i|)·(o − p_i) × d_i
        about the joint (taken at p_i, on the same line of action), and
        τ_a = e_x·Σ_i M_i,  τ_b = (0, cos a, sin a)·Σ_i M_i
        (the same τ_j = a·(o × F − G) as in the module docstring). Both d_i and (o − p_i) × d_i
        are linear in the nine products u_α·v_β of u = (1, cos a, sin a) and v = (1, cos b, sin b):
        one map per section (built once from its span h and the pinholes of the cables crossing
        it, :meth:`_build_one_link_map`) gives all its spans' segments and unit-tension moments
        in one matmul.
        """
        n = self.n_links
        trig = np.empty((3, 2 * n))  # rows: 1, cos q, sin q
        trig[0] = 1.0
        np.cos(q, out=trig[1])
        np.sin(q, out=trig[2])
        trig3 = trig.reshape(3, n, 2)
        u, v = trig3[:, :, 0], trig3[:, :, 1]  # (3, n): (1, cos, sin) of a and of b, per span
        products = (u[:, None, :] * v[None, :, :]).reshape(9, n)  # u_α·v_β, row 3α + β
        tensions = np.asarray(tensions, dtype=np.float64)
        moment = np.empty((3, n))  # Σ_i M_i per span, N·m
        lengths = np.zeros(tensions.shape[-1])
        for first, stop, cables, link_map in self._sections:
            k = link_map.shape[0] // 6  # cables crossing the section
            mapped = link_map @ products[:, first:stop]  # (6k, spans)
            seg = mapped[: 3 * k].reshape(k, 3, -1)  # d_i [cable, xyz, span], m
            lever = mapped[3 * k :].reshape(3, k, -1)  # (o − p_i) × d_i [xyz, cable, span], m²
            seg_len = np.sqrt((seg * seg).sum(axis=1))  # |d_i| (k cables, spans), m
            if tensions.ndim == 1:
                t = tensions[cables].reshape(k, 1)
            else:  # per span (one link per span: the links first:stop are those spans)
                t = tensions[first:stop, cables].T
            moment[:, first:stop] = (lever * (t / seg_len)).sum(axis=1)
            lengths[cables] += seg_len.sum(axis=1)
        tau = np.empty(self.n_dof)
        tau[0::2] = moment[0]
        tau[1::2] = moment[1] * u[1] + moment[2] * u[2]
        if self._corrected:
            lengths += self.rigid_lengths
        return tau, lengths

    @staticmethod
    def _build_one_link_map(
        pinholes: np.ndarray,
        half: float,
        b_out: float = 0.0,
        b_in: float = 0.0,
        distal: np.ndarray | None = None,
    ) -> np.ndarray:
        """The (6k, 9) map of :meth:`_cable_loads_one_link` for one section: from the products
        u_α·v_β (row 3α + β) of one of its spans to the segments d_i (rows 0..3k−1,
        [cable, xyz], m) and the levers (o − p_i) × d_i (rows 3k..6k−1, [xyz, cable], m²) of
        the k cables crossing it, whose pinholes are ``pinholes`` (k, 3) m on the proximal disk
        and ``distal`` (k, 3) m on the distal one (default: the same; helical routing: its
        own span's); ``half`` = h/2 (m). With via-points (``"corrected"`` routing) the segment
        starts at p_i + b_out·z on the proximal disk and ends at the distal pinhole − b_in·Z
        (m)."""
        one, cos, sin = 0, 1, 2  # indices into u = (1, cos a, sin a) and v = (1, cos b, sin b)

        def term(alpha: int, beta: int, vector) -> np.ndarray:
            """``vector`` (3,) times u_α·v_β, as coefficients (3, 9)."""
            out = np.zeros((3, 9))
            out[:, 3 * alpha + beta] = vector
            return out

        k = pinholes.shape[0]
        col_x = term(one, cos, (1, 0, 0)) + term(sin, sin, (0, 1, 0)) + term(cos, sin, (0, 0, -1))
        col_y = term(cos, one, (0, 1, 0)) + term(sin, one, (0, 0, 1))
        col_z = term(one, sin, (1, 0, 0)) + term(sin, cos, (0, -1, 0)) + term(cos, cos, (0, 0, 1))
        centre = half * (term(one, one, (0, 0, 1)) + col_z)  # the distal disk centre o + (h/2)·Z
        joint = np.array([0.0, 0.0, half])
        seg, lever = [], []
        for p, q in zip(pinholes, pinholes if distal is None else distal):
            d = centre + q[0] * col_x + q[1] * col_y
            if b_in != 0.0 or b_out != 0.0:
                p = p + np.array([0.0, 0.0, b_out])
                d = d - b_in * col_z
            d = d - term(one, one, p)  # (3, 9)
            seg.append(d)
            lever.append(np.cross(joint - p, d.T).T)
        return np.concatenate(
            [np.stack(seg).reshape(3 * k, 9), np.stack(lever, axis=1).reshape(3 * k, 9)]
        )

    def gravity_loads(self, q: np.ndarray, pose: ChainPose | None = None) -> np.ndarray:
        """Generalized gravity forces (2n,) N·m: joint j carries the weight of links j..n.

        τ_j = a·((S_j − M_j·o_j) × g) with M_j = Σ_{k≥j} m_k and S_j = Σ_{k≥j} m_k·c_k
        (c_k: link COMs). Zeros when the model was built with ``gravity=False``.
        """
        if not self.gravity:
            return np.zeros(self.n_dof)
        pose = self.pose(q) if pose is None else pose
        w = self._weights  # m_k·g
        # Σ_{k≥j} (c_k − o_j) × m_k g = Σ_{k≥j} c_k × m_k g − o_j × Σ_{k≥j} m_k g
        cw = np.cumsum(_cross(pose.coms, w)[::-1], axis=0)[::-1]
        wsum = np.cumsum(w[::-1], axis=0)[::-1]
        moment = cw - _cross(pose.joint_points, wsum)
        return (pose.joint_axes * moment[:, None, :]).sum(axis=-1).reshape(-1)

    # ------------------------------------------------------------------ statics

    def static_equilibrium(
        self,
        tensions: np.ndarray,
        gravity_bias=None,
        *,
        tol: float = 1e-14,
        max_iter: int = 1000,
        max_angle: float = 0.5 * math.pi,
    ) -> tuple[np.ndarray, bool]:
        """Joint angles of the static equilibrium K·q = τ_cable(q) + τ_gravity(q).

        Fixed-point iteration q ← K⁻¹·(τ_cable(q) + τ_gravity(q)) from the straight pose q = 0,
        to max |Δq| < ``tol`` rad. It converges because the load stiffnesses (the cables'
        ≲ ΣT·Δ/4 per joint, gravity's ≲ m·g·ℓ) are small against K = EI/Δ: the contraction
        factor is their ratio (≈ 0.1–0.3 at the maximum tension with m = 1, less with more
        links). Its limit is the stable equilibrium the dynamics settle to.

        Args:
            tensions: (C,) N.
            gravity_bias: optional callable q -> b(q) (2n,), the joint torques that hold the
                chain against gravity (``BulletBackend`` passes pybullet's inverse dynamics);
                default −:meth:`gravity_loads`.
            tol, max_iter, max_angle: convergence tolerance (rad), iteration limit, and the joint
                angle (rad) beyond which the iteration is declared diverged.

        Returns:
            ``(q, converged)``; the same tensions always give the same bits.
        """
        tensions = np.asarray(tensions, dtype=np.float64)
        k = self.stiffness
        q = np.zeros(self.n_dof)
        for _ in range(max_iter):
            tau, _ = self.cable_loads(q, tensions)
            if gravity_bias is not None:
                tau = tau - gravity_bias(q)
            elif self.gravity:
                tau = tau + self.gravity_loads(q)
            q_new = tau / k
            step = np.max(np.abs(q_new - q))
            q = q_new
            if not (step <= max_angle and np.max(np.abs(q)) <= max_angle):  # NaN fails too
                return q, False
            if step < tol:
                return q, True
        return q, False


def bending_modes(mass: np.ndarray, stiffness: np.ndarray) -> tuple[float, float]:
    """Lowest and highest angular frequency (rad/s) of K·v = ω²·M·v for a diagonal K.

    ``mass`` (2n, 2n) kg·m², ``stiffness`` (2n,) N·m/rad. With K = k·I (one section) the
    frequencies are √(k / eig(M)); otherwise those of the symmetric K^{-1/2}·M·K^{-1/2}.
    """
    if np.all(stiffness == stiffness[0]):
        eig = np.linalg.eigvalsh(mass)  # ascending
        k = float(stiffness[0])
        return float(math.sqrt(k / eig[-1])), float(math.sqrt(k / eig[0]))
    scale = 1.0 / np.sqrt(stiffness)
    eig = np.linalg.eigvalsh(mass * scale[:, None] * scale[None, :])
    return float(math.sqrt(1.0 / eig[-1])), float(math.sqrt(1.0 / eig[0]))
