"""Piecewise constant curvature (PCC) model of a robot of S sections and C cables (SPEC §6).

Pure numpy (no simulator, no Gymnasium), float64, SI units. Every method broadcasts over leading
batch dimensions.

Shape state: the per-section *bending vectors* w_j = θ_j·(cos φ_j, sin φ_j) (rad), an array of
shape (..., S, 2), proximal section first. w_j is expressed in section j's base frame (the frame
of the previous section's end disk, whose x axis is the disks' x axis: the sections compose
without torsion), so the cable geometry, the same in every disk, is the same vector in every
section's frame. Nothing is singular at θ_j = 0 in this representation, and both the cable
lengths and the tension statics are linear in it:

* statics (frictionless cables, pure moments, dense disks):
  w_j = (ℓ_j/EI)·Σ_{cables i through section j} T_i·r_i·(cos β_i, sin β_i); a cable of section
  m passes (and bends) sections 1…m;
* cable lengths: a cable of section m at (r, β) has length Σ_{j≤m} (ℓ_j − r·(w_j·(cos β, sin β))).

Section j's transform (in its base frame) is R_j = Rz(φ_j)·Ry(θ_j)·Rz(−φ_j), written as
R_j = I + (sin θ/θ)·[a]× + ((1 − cos θ)/θ²)·[a]×² with a = (−w_y, w_x, 0), and
p_j = ℓ_j·(f·w_x, f·w_y, g) with (f, g) = ((1 − cos θ)/θ², sin θ/θ) (:func:`arc.arc_profile`),
all exact at θ = 0. The tip is the composition of the S transforms in the base frame R0 (base
disk centre, backbone along +Z0, the disks' x axis along +X0).
"""

from __future__ import annotations

import math
from operator import mul

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
        cable_vectors: r_i·(cos β_i, sin β_i) (m), shape (C, 2), in the disks' frame.
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
        angles = np.asarray(params.cable_angles, dtype=np.float64)
        radii = np.asarray(params.cable_radii, dtype=np.float64)
        self.cable_section = owner = np.asarray(params.cable_section, dtype=np.intp)
        self.cable_vectors = v = radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], -1)
        ei = params.bending_stiffness
        through = owner[:, None] >= np.arange(S)[None, :]  # (C, S): cable i passes section j
        self.cable_through = through
        a = through[:, :, None] * (self.section_lengths[None, :, None] / ei) * v[:, None, :]
        self.tension_to_bending = a.reshape(C, 2 * S)
        b = -(through[:, :, None] * v[:, None, :])  # (C, S, 2)
        self.bending_to_lengths = np.ascontiguousarray(b.reshape(C, 2 * S).T)
        self.straight_lengths = through.astype(np.float64) @ self.section_lengths
        self.lengths_to_bending = self._sequential_least_squares()
        self._bending_to_lengths_columns = self.bending_to_lengths.T.tolist()
        self._tension_to_bending_rows = self.tension_to_bending.T.tolist()
        self._straight_list = self.straight_lengths.tolist()
        self._section_length_list = self.section_lengths.tolist()
        self._tiled: dict[int, np.ndarray] = {}
        self._buffers: dict[int, np.ndarray] = {}
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
        S, C, v, owner = self.n_sections, self.n_cables, self.cable_vectors, self.cable_section
        maps = np.zeros((S, 2, C))  # w_j = maps[j] @ Δl
        for j in range(S):
            own = np.flatnonzero(owner == j)
            rows = np.eye(C)[own]  # y_i = Δl_i + Σ_{k<j} v_i·w_k, as linear maps of Δl
            for k in range(j):
                rows = rows + v[own] @ maps[k]
            design = np.concatenate([np.ones((own.size, 1)), -v[own]], axis=1)
            maps[j] = (np.linalg.pinv(design) @ rows)[1:]
        return np.ascontiguousarray(maps.transpose(2, 0, 1).reshape(C, 2 * S))

    def bending_from_tensions(self, tensions) -> np.ndarray:
        """Bending vectors w (..., S, 2) (rad) under cable tensions (..., C) (N) (SPEC §6 statics).

        w_j = (ℓ_j/EI)·Σ_{cables i through section j} T_i r_i (cos β_i, sin β_i). Linear; negative
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

        A cable of section m at (r, β): Σ_{j≤m} (ℓ_j − r·(w_j·(cos β, sin β))).
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

        Sequential least squares per section from the base (SPEC §6; see
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
    # The hot path (called every env step on (N, S, 2) arrays) works component-major on
    # (S, N) rows, so every numpy call runs over the whole batch, and writes its intermediates into
    # scratch buffers kept per batch size: allocating fresh 128 kB temporaries costs more than the
    # arithmetic (page faults). Consequently a PCCModel must not be shared between threads.
    def _scratch(self, rows: int) -> np.ndarray:
        buf = self._buffers.get(rows)
        if buf is None:
            if len(self._buffers) > 8:
                self._buffers.clear()
            buf = self._buffers[rows] = np.empty((10 * self.n_sections + 7, rows))
        return buf

    def _profile(self, w):
        """(wx, wy, f, g, h = cos θ), each (S, M) rows of a scratch buffer, 7 free scratch rows
        (7, M) and the batch shape; M = batch size."""
        w = _finite("w", w)
        S = self.n_sections
        if w.shape[-2:] != (S, 2):
            raise ValueError(f"w must have shape (..., {S}, 2), got {w.shape}")
        batch = w.shape[:-2]
        flat = w.reshape(-1, 2 * S)
        buf = self._scratch(flat.shape[0])
        comp = buf[: 2 * S]
        np.copyto(comp, flat.T)
        return self._profile_rows(comp, buf) + (batch,)

    def _profile_rows(self, comp: np.ndarray, buf: np.ndarray):
        """(wx, wy, f, g, h, tmp) from the component rows ``comp`` (2S, M) = (wx_0, wy_0, wx_1,
        …); ``buf`` is the scratch buffer of M rows (``comp`` may be its first 2S rows)."""
        S = self.n_sections
        rest, tmp = buf[2 * S : 10 * S], buf[10 * S :]
        wx, wy = comp[0::2], comp[1::2]
        th2, x, safe, p, t, den, g, f = (rest[k * S : (k + 1) * S] for k in range(8))
        np.multiply(wx, wx, out=th2)
        np.multiply(wy, wy, out=x)
        th2 += x
        np.sqrt(th2, out=x)
        x *= 0.25  # θ/4
        np.add(x, 1e-300, out=safe)  # == x unless x < 1e-284; tan(1e-300)/1e-300 == 1.0 exactly
        np.tan(safe, out=p)
        p /= safe  # tan(θ/4)/(θ/4)
        np.multiply(p, x, out=t)
        t *= t  # tan²(θ/4)
        np.add(t, 1.0, out=den)
        p /= den  # q = sin(θ/2)/(θ/2)
        np.subtract(1.0, t, out=g)
        g *= p
        g /= den  # sin θ/θ = q·cos(θ/2)
        np.multiply(p, p, out=f)
        f *= 0.5  # (1 − cos θ)/θ² = q²/2
        h = x  # reuse: cos θ = 1 − f θ²
        np.multiply(f, th2, out=h)
        np.subtract(1.0, h, out=h)
        return wx, wy, f, g, h, tmp

    @staticmethod
    def _rotate_into(wx, wy, f, g, h, v, tmp) -> None:
        """v (3, M) <- R(w)·v, R = I + g[a]× + f[a]×², h = cos θ; tmp: (4, M) scratch."""
        c, d, gv3, fd = tmp[0], tmp[1], tmp[2], tmp[3]
        np.multiply(wx, v[0], out=c)
        np.multiply(wy, v[1], out=d)
        c += d  # w·v
        np.multiply(wx, v[1], out=d)
        np.multiply(wy, v[0], out=gv3)
        d -= gv3  # (−wy, wx)·v
        np.multiply(g, v[2], out=gv3)
        np.multiply(f, d, out=fd)
        v *= h
        np.multiply(wx, gv3, out=d)
        v[0] += d
        np.multiply(wy, fd, out=d)
        v[0] -= d
        np.multiply(wy, gv3, out=d)
        v[1] += d
        np.multiply(wx, fd, out=d)
        v[1] += d
        np.multiply(g, c, out=d)
        v[2] -= d

    def _tip_into(self, wx, wy, f, g, h, v, tmp) -> None:
        """v (3, M) <- the tip (m) from the (S, M) components."""
        ell = self.section_lengths
        for j in range(self.n_sections - 1, -1, -1):
            if j < self.n_sections - 1:
                self._rotate_into(wx[j], wy[j], f[j], g[j], h[j], v, tmp)
                np.multiply(f[j], wx[j], out=tmp[0])
                tmp[0] *= ell[j]
                v[0] += tmp[0]
                np.multiply(f[j], wy[j], out=tmp[0])
                tmp[0] *= ell[j]
                v[1] += tmp[0]
                np.multiply(g[j], ell[j], out=tmp[0])
                v[2] += tmp[0]
            else:
                np.multiply(f[j], wx[j], out=v[0])
                np.multiply(f[j], wy[j], out=v[1])
                v[:2] *= ell[j]
                np.multiply(g[j], ell[j], out=v[2])

    def _direction_into(self, wx, wy, f, g, h, v, tmp) -> None:
        """v (3, M) <- the unit tangent at the tip from the (S, M) components."""
        last = self.n_sections - 1
        np.multiply(g[last], wx[last], out=v[0])
        np.multiply(g[last], wy[last], out=v[1])
        np.copyto(v[2], h[last])
        for j in range(last - 1, -1, -1):
            self._rotate_into(wx[j], wy[j], f[j], g[j], h[j], v, tmp)

    @staticmethod
    def _pack(v: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
        """A fresh (..., 3) array from the rows v (3, M) (column writes: v.T.copy() is slower)."""
        out = np.empty((v.shape[1], 3))
        out[:, 0], out[:, 1], out[:, 2] = v
        return out.reshape(batch + (3,))

    def tip_from_bending(self, w) -> np.ndarray:
        """Tip position (..., 3) (m) in R0 of the shape w (..., S, 2) (rad)."""
        wx, wy, f, g, h, tmp, batch = self._profile(w)
        self._tip_into(wx, wy, f, g, h, tmp[:3], tmp[3:])
        return self._pack(tmp[:3], batch)

    def tip_direction_from_bending(self, w) -> np.ndarray:
        """Unit backbone tangent at the tip, (..., 3), in R0 (the tip frame's z axis)."""
        wx, wy, f, g, h, tmp, batch = self._profile(w)
        self._direction_into(wx, wy, f, g, h, tmp[:3], tmp[3:])
        return self._pack(tmp[:3], batch)

    def tip_and_direction_from_bending(self, w) -> tuple[np.ndarray, np.ndarray]:
        """``(tip_from_bending(w), tip_direction_from_bending(w))``, sharing the arc profile."""
        wx, wy, f, g, h, tmp, batch = self._profile(w)
        self._tip_into(wx, wy, f, g, h, tmp[:3], tmp[3:])
        tip = self._pack(tmp[:3], batch)
        self._direction_into(wx, wy, f, g, h, tmp[:3], tmp[3:])
        return tip, tmp[:3].T.copy().reshape(batch + (3,))

    def _forward_one(self, comp: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`forward_rows` for one robot (M = 1): rows of :meth:`forward_values_one`."""
        rows = np.array(self.forward_values_one(comp))[:, None]
        return rows[0:3], rows[3:6], rows[6:]

    def bending_values_one(self, tensions: list[float]) -> list[float]:
        """:meth:`bending_rows_from_tensions` of one robot in Python floats: the bending
        components (wx_0, wy_0, wx_1, …) (2S,) rad from tensions (C,) N (finite, validated by
        the caller), as a list."""
        return [sum(map(mul, row, tensions)) for row in self._tension_to_bending_rows]

    def forward_values_one(self, comp: np.ndarray | list[float]) -> list[float]:
        """Tip (3) m, tip direction (3) and cable lengths (C) m, as one list of Python floats,
        of one robot's bending components ``comp``: rows (2S, 1), or the (2S,) values as a list
        (finite: the caller validates).

        The same formulas in the same order as :meth:`_profile_rows`, :meth:`_tip_into` and
        :meth:`_direction_into` (for any S): at M = 1 each numpy call costs ~1 µs of overhead
        for one number, which made the single env several times slower than the batched one
        per robot. Results agree with the rows kernel to rounding (tests/test_model_chain.py).
        """
        vals = comp[:, 0].tolist() if isinstance(comp, np.ndarray) else comp
        ell = self._section_length_list
        prof = []
        for j in range(self.n_sections):
            wx, wy = vals[2 * j], vals[2 * j + 1]
            th2 = wx * wx + wy * wy
            x = math.sqrt(th2) * 0.25
            safe = x + 1e-300
            p = math.tan(safe) / safe
            t = p * x
            t *= t
            den = t + 1.0
            p /= den
            g = (1.0 - t) * p / den
            f = p * p * 0.5
            prof.append((wx, wy, f, g, 1.0 - f * th2))

        last = self.n_sections - 1
        wx, wy, f, g, h = prof[last]
        p0, p1, p2 = f * wx * ell[last], f * wy * ell[last], g * ell[last]
        d0, d1, d2 = g * wx, g * wy, h
        for j in range(last - 1, -1, -1):
            wx, wy, f, g, h = prof[j]
            p0, p1, p2 = _rotate_one(prof[j], p0, p1, p2)
            p0 += f * wx * ell[j]
            p1 += f * wy * ell[j]
            p2 += g * ell[j]
            d0, d1, d2 = _rotate_one(prof[j], d0, d1, d2)
        values = [p0, p1, p2, d0, d1, d2]
        for column, straight in zip(self._bending_to_lengths_columns, self._straight_list):
            values.append(sum(map(mul, column, vals)) + straight)
        return values

    # -- the same, field-major: the batched backend's hot path ----------------------------------
    def bending_rows_from_tensions(self, tensions: np.ndarray) -> np.ndarray:
        """Bending components as rows (2S, M) = (wx_0, wy_0, wx_1, …) (rad) from tensions (M, C)
        (N; any memory layout, finite: the caller validates). A fresh array."""
        return self.tension_to_bending.T @ tensions.T

    def forward_rows(self, comp: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tip (3, M) m, tip direction (3, M) and cable lengths (C, M) m, as fresh row arrays,
        of the bending component rows ``comp`` (2S, M) (finite: the caller validates).

        Field-major twin of :meth:`tip_and_direction_from_bending` and
        :meth:`lengths_from_bending` (same arithmetic): with one row per component, every numpy
        call runs over the whole batch and no transposing copy is needed; ``.T`` of the results
        gives (M, ·) arrays (Fortran-ordered views).
        """
        m = comp.shape[1]
        if m == 1:
            return self._forward_one(comp)
        buf = self._scratch(m)
        wx, wy, f, g, h, tmp = self._profile_rows(comp, buf)
        tip = np.empty((3, m))
        self._tip_into(wx, wy, f, g, h, tip, tmp)
        direction = np.empty((3, m))
        self._direction_into(wx, wy, f, g, h, direction, tmp)
        lengths = self.bending_to_lengths.T @ comp
        lengths += self.straight_lengths[:, None]
        return tip, direction, lengths

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


def _rotate_one(
    profile: tuple[float, float, float, float, float], v0: float, v1: float, v2: float
) -> tuple[float, float, float]:
    """One section's rotation of the vector (v0, v1, v2) from the arc profile
    (wx, wy, f, g, h) of :meth:`PCCModel.forward_values_one` (Python floats)."""
    wx, wy, f, g, h = profile
    c = wx * v0 + wy * v1
    fd = f * (wx * v1 - wy * v0)
    gv3 = g * v2
    return (
        v0 * h + wx * gv3 - wy * fd,
        v1 * h + wy * gv3 + wx * fd,
        v2 * h - g * c,
    )
