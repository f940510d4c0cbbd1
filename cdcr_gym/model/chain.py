"""Piecewise constant curvature (PCC) model of a robot of S sections and C cables (docs/model.md).

Pure numpy (no simulator, no Gymnasium), float64, SI units. Every method broadcasts over leading
batch dimensions.

Shape state: the per-section *bending vectors* w_j = θ_j·(cos φ_j, sin φ_j) (rad), an array of
shape (..., S, 2), proximal section first. w_j is expressed in section j's base frame (the frame
of the previous section's end disk, whose x axis is the disks' x axis: the sections compose
without torsion), so a cable parallel to the backbone is the same vector in every section's
frame (a helical cable, ``RobotParams.cable_pitch``, turns section by section: v_ij below is
its vector in section j, :meth:`RobotParams.section_cable_vectors`). Nothing is singular at
θ_j = 0 in this representation, and both the cable lengths and the tension statics are linear
in it:

* statics (frictionless cables, pure moments, dense disks):
  w_j = (ℓ_j/EI)·Σ_{cables i through section j} T_i·v_ij with v_ij = r_i·(cos β_i, sin β_i)
  for parallel cables; a cable of section m passes (and bends) sections 1…m;
* cable lengths: a cable i of section m has length Σ_{j≤m} (ℓ_j − w_j·v_ij).

Section j's transform (in its base frame) is R_j = Rz(φ_j)·Ry(θ_j)·Rz(−φ_j), written as
R_j = I + (sin θ/θ)·[a]× + ((1 − cos θ)/θ²)·[a]×² with a = (−w_y, w_x, 0), and
p_j = ℓ_j·(f·w_x, f·w_y, g) with (f, g) = ((1 − cos θ)/θ², sin θ/θ) (:func:`arc.arc_profile`),
all exact at θ = 0. The tip is the composition of the S transforms in the base frame R0 (base
disk centre, backbone along +Z0, the disks' x axis along +X0).
"""

from __future__ import annotations

import math

import numpy as np

from cdcr_gym.model.arc import (
    arc_from_bending,
    as_finite,
    bending_from_arc,
    profile_nonnegative,
)
from cdcr_gym.model.params import RobotParams

__all__ = ["PCCModel"]


def _finite(name: str, x) -> np.ndarray:
    """float64 array of ``x``; ValueError naming ``name`` if any entry is NaN or infinite."""
    x = np.asarray(x, dtype=np.float64)
    if not math.isfinite(np.add.reduce(x, axis=None)):  # one reduction: NaN/inf propagate
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x


def _rotation_matrices(wx, wy, f, g) -> np.ndarray:
    """R = I + g[a]× + f[a]×², a = (−wy, wx, 0): shape (..., 3, 3) from components (...)."""
    fx, fy = f * wx, f * wy
    rot = np.empty(np.shape(wx) + (3, 3))
    rot[..., 0, 0] = 1.0 - fx * wx
    rot[..., 0, 1] = -fx * wy
    rot[..., 0, 2] = g * wx
    rot[..., 1, 0] = rot[..., 0, 1]
    rot[..., 1, 1] = 1.0 - fy * wy
    rot[..., 1, 2] = g * wy
    rot[..., 2, 0] = -rot[..., 0, 2]
    rot[..., 2, 1] = -rot[..., 1, 2]
    rot[..., 2, 2] = 1.0 - (fx * wx + fy * wy)
    return rot


class PCCModel:
    """The PCC kinematics and statics of a :class:`RobotParams` robot, batched.

    Constant matrices (tensions → bending, bending → lengths, lengths → bending) are computed once
    at construction; every method then costs a few numpy calls regardless of the batch size.

    Attributes:
        params: the robot.
        n_sections: S, number of sections.
        n_cables: C, number of cables (cable order of ``params``: section by section).
        section_lengths: ℓ_j (m), shape (S,).
        cable_vectors: r_i·(cos β_i, sin β_i) (m), shape (C, 2), in the disks' frame: each
            cable's vector in its own section (with helical routing its angle there).
        section_cable_vectors: v_ij (m), shape (C, S, 2): cable i's vector in section j, 0
            where it does not pass.
        cable_section: section index (0-based) each cable ends in, shape (C,).
        straight_lengths: cable lengths (m) of the straight robot, shape (C,).
        tension_to_bending: A, shape (C, 2S): w.reshape(..., 2S) = T @ A (rad/N).
        bending_to_lengths: B, shape (2S, C): lengths = straight_lengths + w.reshape(..., 2S) @ B.
        lengths_to_bending: G, shape (C, 2S): the sequential least squares of
            :meth:`bending_from_lengths` as one matrix.
    """

    def __init__(self, params: RobotParams) -> None:
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a RobotParams, got {params!r}")
        self.params = params
        self.n_sections = S = params.n_sections
        self.n_cables = C = params.n_cables
        self.section_lengths = np.asarray(params.section_lengths, dtype=np.float64)
        self.cable_section = owner = np.asarray(params.cable_section, dtype=np.intp)
        #: the cables' radius vectors in every section (C, S, 2), 0 where a cable does not pass
        #: (``RobotParams.section_cable_vectors``: helical routing turns them section by section)
        self.section_cable_vectors = vs = params.section_cable_vectors()
        self.cable_vectors = vs[np.arange(C), owner]  # (C, 2): each cable's in its own section
        ei = params.bending_stiffness
        through = owner[:, None] >= np.arange(S)[None, :]  # (C, S): cable i passes section j
        self.cable_through = through
        a = (self.section_lengths[None, :, None] / ei) * vs
        self.tension_to_bending = a.reshape(C, 2 * S)
        b = -vs  # (C, S, 2)
        self.bending_to_lengths = np.ascontiguousarray(b.reshape(C, 2 * S).T)
        self.straight_lengths = through.astype(np.float64) @ self.section_lengths
        self.lengths_to_bending = self._sequential_least_squares()
        self._lengths_map = self.bending_to_lengths.T  # (C, 2S) of forward_rows
        self._bending_rows = self.tension_to_bending.T  # (2S, C) of bending_rows_from_tensions
        self._straight_column = self.straight_lengths[:, None]
        #: Section lengths (m) as 0-d arrays (the kernel's operands, see ``_ONE``).
        self._section_length_list = [np.array(x) for x in self.section_lengths.tolist()]
        self._half_lengths = 0.5 * self.section_lengths  # (S,): a 0-d batch's
        self._half_length_column = self._half_lengths[:, None]  # (S, 1): a batch of rows'
        # tensions (M, C) -> rows (2S + C, M): the bending components, then the cable-length
        # changes (one product for both: both are linear in the tensions)
        self._tension_rows = np.ascontiguousarray(
            np.concatenate([self._bending_rows, self._lengths_map @ self._bending_rows])
        )
        self._tiled: dict[int, np.ndarray] = {}
        self.disk_fractions = tuple(
            np.arange(1, s.n_disks + 1, dtype=np.float64) / s.n_disks for s in params.sections
        )

    def __repr__(self) -> str:
        return f"PCCModel(n_sections={self.n_sections}, n_cables={self.n_cables})"

    # -- statics and cable lengths (linear) ----------------------------------------------------
    def _sequential_least_squares(self) -> np.ndarray:
        """G (C, 2S) with w.reshape(2S) = (lengths − straight_lengths) @ G.

        Section by section from the base: subtract each cable's run through the (known) proximal
        sections, then fit the section's own cables, Δl_i = c − v_i·w_j, by least squares with a
        free common offset c (a common-mode length error does not bend; exact for consistent
        lengths, and for 3 cables always exact).
        """
        S, C, owner = self.n_sections, self.n_cables, self.cable_section
        v = self.section_cable_vectors  # (C, S, 2)
        maps = np.zeros((S, 2, C))  # w_j = maps[j] @ Δl
        for j in range(S):
            own = np.flatnonzero(owner == j)
            rows = np.eye(C)[own]  # y_i = Δl_i + Σ_{k<j} v_ik·w_k, as linear maps of Δl
            for k in range(j):
                rows = rows + v[own, k] @ maps[k]
            design = np.concatenate([np.ones((own.size, 1)), -v[own, j]], axis=1)
            maps[j] = (np.linalg.pinv(design) @ rows)[1:]
        return np.ascontiguousarray(maps.transpose(2, 0, 1).reshape(C, 2 * S))

    def bending_from_tensions(self, tensions) -> np.ndarray:
        """Bending vectors w (..., S, 2) (rad) under cable tensions (..., C) (N) (coupled statics).

        w_j = (ℓ_j/EI)·Σ_{cables i through section j} T_i v_ij (module docstring). Linear; negative
        tensions are computed as given (callers keep tensions in [0, max_tension]).
        """
        t = _finite("tensions", tensions)
        if t.shape[-1:] != (self.n_cables,):
            raise ValueError(f"tensions must have shape (..., {self.n_cables}), got {t.shape}")
        return (t @ self.tension_to_bending).reshape(t.shape[:-1] + (self.n_sections, 2))

    def _flat_bending(self, w) -> np.ndarray:
        w = _finite("w", w)
        if w.shape[-2:] != (self.n_sections, 2):
            raise ValueError(f"w must have shape (..., {self.n_sections}, 2), got {w.shape}")
        return w.reshape(w.shape[:-2] + (2 * self.n_sections,))

    def lengths_from_bending(self, w) -> np.ndarray:
        """Cable lengths (..., C) (m) of the shape w (..., S, 2) (rad).

        A cable i of section m: Σ_{j≤m} (ℓ_j − w_j·v_ij) (module docstring).
        """
        out = self._flat_bending(w) @ self.bending_to_lengths
        out += self._tiled_straight_lengths(out.shape)
        return out

    def _tiled_straight_lengths(self, shape: tuple[int, ...]) -> np.ndarray:
        """straight_lengths broadcast to ``shape`` as a contiguous array (cached per size).

        Adding a contiguous array is ~10x faster in numpy than broadcasting a (C,) row over many
        rows (a C-long inner loop per row).
        """
        rows = math.prod(shape[:-1])
        tiled = self._tiled.get(rows)
        if tiled is None:
            tiled = np.tile(self.straight_lengths, rows)
            tiled.flags.writeable = False
            if len(self._tiled) > 8:
                self._tiled.clear()
            self._tiled[rows] = tiled
        return tiled.reshape(shape)

    def bending_from_lengths(self, lengths) -> np.ndarray:
        """Bending vectors w (..., S, 2) (rad) from cable lengths (..., C) (m).

        Sequential least squares per section from the base (see
        :attr:`lengths_to_bending`): exact for consistent lengths; a common-mode length change of
        a section's cables does not bend it.
        """
        lengths = _finite("lengths", lengths)
        if lengths.shape[-1:] != (self.n_cables,):
            raise ValueError(f"lengths must have shape (..., {self.n_cables}), got {lengths.shape}")
        if np.any(lengths < 0.0):
            raise ValueError(f"lengths (cable lengths) must be >= 0 m, got {lengths!r}")
        flat = (lengths - self.straight_lengths) @ self.lengths_to_bending
        return flat.reshape(lengths.shape[:-1] + (self.n_sections, 2))

    # -- arcs ----------------------------------------------------------------------------------
    @staticmethod
    def arcs_from_bending(w) -> tuple[np.ndarray, np.ndarray]:
        """(θ, φ) per section, each (..., S) (rad), of w (..., S, 2); φ = 0 where θ = 0."""
        return arc_from_bending(_finite("w", w))

    @staticmethod
    def bending_from_arcs(theta, phi) -> np.ndarray:
        """w (..., S, 2) (rad) from θ, φ (..., S) (rad): w_j = θ_j (cos φ_j, sin φ_j)."""
        return bending_from_arc(as_finite("theta", theta), as_finite("phi", phi))

    # -- forward kinematics ----------------------------------------------------------------------
    # One kernel (:func:`_tip_and_direction`) serves every caller: numpy arithmetic on the
    # bending components stacked section-major, (S, 2, *batch), written into one (6, *batch)
    # array (tip, then direction).
    def _kinematics(self, w) -> tuple[np.ndarray, np.ndarray]:
        """Tip (..., 3) m and unit tip tangent (..., 3) of w (..., S, 2) (rad)."""
        w = _finite("w", w)
        S = self.n_sections
        if w.shape[-2:] != (S, 2):
            raise ValueError(f"w must have shape (..., {S}, 2), got {w.shape}")
        batch = w.shape[:-2]
        rows = np.moveaxis(w, (-2, -1), (0, 1)).reshape((2 * S,) + batch)
        half = self._half_lengths.reshape((S,) + (1,) * len(batch))
        out = _tip_and_direction(rows, self._section_length_list, half, np.empty((6,) + batch))
        both = np.moveaxis(out, 0, -1)
        return both[..., :3], both[..., 3:]

    def tip_from_bending(self, w) -> np.ndarray:
        """Tip position (..., 3) (m) in R0 of the shape w (..., S, 2) (rad)."""
        return self._kinematics(w)[0]

    def tip_direction_from_bending(self, w) -> np.ndarray:
        """Unit backbone tangent at the tip, (..., 3), in R0 (the tip frame's z axis)."""
        return self._kinematics(w)[1]

    def tip_and_direction_from_bending(self, w) -> tuple[np.ndarray, np.ndarray]:
        """``(tip_from_bending(w), tip_direction_from_bending(w))``, computed together."""
        return self._kinematics(w)

    # -- the same, field-major: the backend's hot path -------------------------------------------
    def bending_rows_from_tensions(self, tensions: np.ndarray) -> np.ndarray:
        """Bending components as rows (2S, M) = (wx_0, wy_0, wx_1, …) (rad) from tensions (M, C)
        (N; any memory layout, finite: the caller validates). A fresh array."""
        return self._bending_rows @ tensions.T

    def forward_rows(self, comp: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tip (3, M) m, tip direction (3, M) and cable lengths (C, M) m, as fresh row arrays,
        of the bending component rows ``comp`` (2S, M) (finite: the caller validates).

        Field-major twin of :meth:`tip_and_direction_from_bending` and
        :meth:`lengths_from_bending` (the same kernel): ``.T`` of the results gives (M, ·)
        arrays (Fortran-ordered views).
        """
        both = _tip_and_direction(
            comp, self._section_length_list, self._half_length_column, np.empty((6, comp.shape[1]))
        )
        lengths = self._lengths_map @ comp + self._straight_column
        return both[:3], both[3:], lengths

    def forward_rows_from_tensions(
        self, tensions: np.ndarray
    ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The bending component rows (2S, M) (rad) held by ``tensions`` (M, C) (N; any memory
        layout, finite: the caller validates) and their :meth:`forward_rows` (tip (3, M) m,
        tip direction (3, M), cable lengths (C, M) m): the same results, with the bending and
        the length changes from one matrix product. Fresh arrays."""
        rows = self._tension_rows @ tensions.T
        split = 2 * self.n_sections
        comp, lengths = rows[:split], rows[split:] + self._straight_column
        both = _tip_and_direction(
            comp, self._section_length_list, self._half_length_column, np.empty((6, rows.shape[1]))
        )
        return comp, (both[:3], both[3:], lengths)

    def section_frames(self, w) -> np.ndarray:
        """Homogeneous frames (..., S+1, 4, 4) in R0: the base frame, then every section's end.

        Translations in m. Frame j+1 = frame j · [R_j, p_j; 0, 1] (no torsion).
        """
        w = _finite("w", w)
        if w.shape[-2:] != (self.n_sections, 2):
            raise ValueError(f"w must have shape (..., {self.n_sections}, 2), got {w.shape}")
        wx, wy = w[..., 0], w[..., 1]
        f, g = profile_nonnegative(np.sqrt(wx * wx + wy * wy))
        rot = _rotation_matrices(wx, wy, f, g)  # (..., S, 3, 3)
        ell = self.section_lengths
        pos = np.stack([ell * f * wx, ell * f * wy, ell * g], axis=-1)  # (..., S, 3)
        batch = w.shape[:-2]
        frames = np.zeros(batch + (self.n_sections + 1, 4, 4))
        frames[..., :, 3, 3] = 1.0
        frames[..., 0, :3, :3] = np.eye(3)
        for j in range(self.n_sections):
            r_prev, p_prev = frames[..., j, :3, :3], frames[..., j, :3, 3]
            frames[..., j + 1, :3, :3] = r_prev @ rot[..., j, :, :]
            frames[..., j + 1, :3, 3] = p_prev + (r_prev @ pos[..., j, :, None])[..., 0]
        return frames

    def pose_from_bending(self, w) -> np.ndarray:
        """Tip frame (..., 4, 4) in R0 (rotation; translation in m)."""
        return self.section_frames(w)[..., -1, :, :]

    def _stations(self, w, fractions) -> tuple[np.ndarray, np.ndarray]:
        """Centres (..., 1+Σn_j, 3) and rotations (..., 1+Σn_j, 3, 3) at arc fractions of sections.

        ``fractions[j]`` (shape (n_j,), in (0, 1]) are positions within section j; a sub-arc of
        length σℓ_j has bending vector σw_j. The base (identity at the origin) comes first.
        """
        frames = self.section_frames(w)
        w = np.asarray(w, dtype=np.float64)
        centres, rotations = (
            [np.zeros(w.shape[:-2] + (1, 3))],
            [np.broadcast_to(np.eye(3), w.shape[:-2] + (1, 3, 3))],
        )
        for j, sigma in enumerate(fractions):
            sub = w[..., j, None, :] * sigma[:, None]  # (..., n, 2)
            sx, sy = sub[..., 0], sub[..., 1]
            f, g = profile_nonnegative(np.sqrt(sx * sx + sy * sy))
            length = self.section_lengths[j] * sigma
            local_p = np.stack([length * f * sx, length * f * sy, length * g], axis=-1)
            local_r = _rotation_matrices(sx, sy, f, g)
            r_base = frames[..., j, None, :3, :3]
            p_base = frames[..., j, None, :3, 3]
            centres.append(p_base + (r_base @ local_p[..., None])[..., 0])
            rotations.append(r_base @ local_r)
        return np.concatenate(centres, axis=-2), np.concatenate(rotations, axis=-3)

    def backbone_points(self, w, points_per_section: int = 16) -> np.ndarray:
        """Points along the backbone (..., P, 3) in R0 (m), base first, tip last.

        Each section contributes the points at arc fractions k/points_per_section
        (k = 1…points_per_section) and at every one of its disk stations (duplicates merged),
        in order along the backbone; P = 1 + Σ_j (that count).
        """
        if (
            isinstance(points_per_section, bool)
            or not isinstance(points_per_section, (int, np.integer))
            or points_per_section < 1
        ):
            raise ValueError(
                f"points_per_section must be an integer >= 1, got {points_per_section!r}"
            )
        fractions = []
        for disks in self.disk_fractions:
            even = np.arange(1, points_per_section + 1) / points_per_section
            near = np.min(np.abs(even[:, None] - disks[None, :]), axis=1) < 1e-9
            fractions.append(np.sort(np.concatenate([disks, even[~near]])))
        return self._stations(w, fractions)[0]

    def disk_frames(self, w) -> tuple[np.ndarray, np.ndarray]:
        """Centres (..., D+1, 3) (m) and rotations (..., D+1, 3, 3) of the base disk and every
        spacer disk (D = params.n_disks; n_disks_j per section, evenly spaced, the last at the
        section's end), in R0, proximal first. A rotation's z column is the backbone tangent, its
        x column the disk's x axis (cable angles β are measured from it)."""
        return self._stations(w, self.disk_fractions)


# Constants of the kernels as 0-d float64 arrays: the same values and bits as Python floats,
# and cheaper operands for numpy on small arrays (no Python-scalar conversion per operation).
_ONE, _TWO, _HALF, _TINY = (np.array(c) for c in (1.0, 2.0, 0.5, 1e-300))


def _arc_profile(wx, wy, half_ell):
    """(fℓ, g, h) = (ℓ·(1 − cos θ)/θ², sin θ/θ, cos θ) of the bending components (wx, wy)
    (float64 arrays (S, *batch)), θ = |w|, with ``half_ell`` the section lengths / 2 (m),
    broadcasting against them. Exact and finite at θ = 0 (tan(1e-300)/1e-300 == 1.0).

    From u = tan(θ/2) and r = u/(θ/2): sin θ/θ = r/(1 + u²), (1 − cos θ)/θ² = r·(sin θ/θ)/2
    and cos θ = 2/(1 + u²) − 1 (exact identities for every θ; no cancellation near 0). One
    transcendental function besides the square root, and few numpy calls (each call, not
    each element, is what costs at small batches; fresh results, not in-place operations,
    which cost ~2.5 calls each on a few elements)."""
    y = np.sqrt(wx * wx + wy * wy) * _HALF + _TINY  # θ/2 (+ 1e-300: the same unless < 1e-284)
    u = np.tan(y)
    r = u / y  # tan(θ/2)/(θ/2)
    den = u * u + _ONE  # 1 + u²
    g = r / den  # sin θ/θ
    return r * g * half_ell, g, _TWO / den - _ONE  # ℓ·(1 − cos θ)/θ², sin θ/θ, cos θ


def _rotate(wx, wy, f, g, h, v0, v1, v2):
    """R(w)·v with R = I + g[a]× + f[a]×², a = (−wy, wx, 0), h = cos θ."""
    c = wx * v0 + wy * v1
    fd = f * (wx * v1 - wy * v0)
    gv3 = g * v2
    return v0 * h + wx * gv3 - wy * fd, v1 * h + wy * gv3 + wx * fd, v2 * h - g * c


def _tip_and_direction(
    w: np.ndarray, ell: list[np.ndarray], half_ell: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """Tip (m) and unit tip tangent of the bending components ``w`` (2S, *batch) (rad; rows
    wx_0, wy_0, wx_1, …) of S sections of lengths ``ell`` (m, 0-d arrays; ``half_ell`` the
    halves, shape (S,) + (1,)·len(batch)), composed from the distal section to the base,
    written into ``out`` (6, *batch): rows tip x, y, z, then tangent x, y, z. Returns ``out``."""
    fl, g, h = _arc_profile(w[0::2], w[1::2], half_ell)  # each (S, *batch)
    last = len(ell) - 1
    wl, gl = w[2 * last : 2 * last + 2], g[last]
    np.multiply(wl, fl[last], out[0:2])
    np.multiply(gl, ell[last], out[2:3])  # (slices: also for a 0-d batch)
    np.multiply(wl, gl, out[3:5])
    out[5:6] = h[last]
    if last == 0:
        return out
    p0, p1, p2, d0, d1, d2 = out
    for j in range(last - 1, -1, -1):
        wx, wy, gj, hj = w[2 * j], w[2 * j + 1], g[j], h[j]
        fj = fl[j] / ell[j]
        p0, p1, p2 = _rotate(wx, wy, fj, gj, hj, p0, p1, p2)
        p0 = p0 + fl[j] * wx
        p1 = p1 + fl[j] * wy
        p2 = p2 + gj * ell[j]
        d0, d1, d2 = _rotate(wx, wy, fj, gj, hj, d0, d1, d2)
    out[0], out[1], out[2], out[3], out[4], out[5] = p0, p1, p2, d0, d1, d2
    return out
