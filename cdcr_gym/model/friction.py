"""Capstan friction between a cable and the disks it runs through, pure numpy.

A cable runs straight from pinhole to pinhole. At a disk its incoming and outgoing segments meet
at the *wrap angle* α (the angle between their directions); a cable sliding through that pinhole
carries, on the side away from where it is pulled, ``T_out = T_in·e^(−μα)`` (the capstan
equation), and in stick any ratio inside ``[e^(−μα), e^(μα)]``. The actuator pulls at the base:

* pulling (the cable slides towards the base) — the tension falls disk by disk towards the
  anchor: the segment beyond disk k carries ``T_k = T_{k−1}·e^(−μ α_k)``;
* releasing (the cable slides towards the tip) — it rises: ``T_k = T_{k−1}·e^(+μ α_k)``.

**Regularised stick–slip.** The sign is replaced by a *slip state* s ∈ [−1, 1] (+1 pulling,
−1 releasing) and the factor across a disk by ``e^(−s·μ·α_k)``, which stays inside the stick
band for every |s| ≤ 1 (|s| < 1 is stick: the ratio is one of the admissible stick ratios). Two
laws for s are provided, both documented in ``docs/experiments/sim2real.md`` (capstan friction):

* :func:`slip_from_speed` — ``s = tanh(v / v_s)`` of the cable's sliding speed v (m/s,
  positive towards the base) over a velocity scale v_s. Memoryless: at rest s = 0, so the
  tensions equalise (frictionless statics) once the cable stops; smooth in v, which keeps an
  explicit integrator stable, but no hysteresis survives settling.
* :func:`update_slip` — a displacement-regularised (Dahl-type) law: s relaxes towards the sign
  of the sliding displacement over a slip length x_s, ``ds = (dx/x_s)·(1 − s·sign(dx))``, solved
  exactly per step. s is a state with memory: a cable that stops keeps its last profile
  (stick), so load–unload cycles open a hysteresis loop whose width tends to the Coulomb
  (sign) limit as x_s → 0, and the profile is continuous in the displacement for x_s > 0.

The whole cable slides together (it is inextensible), so one s per cable applies at every disk.

Shapes: a cable with D + 1 pinholes (base disk first, the anchor disk last) has D segments and
D wrap angles (the base disk's and those of the D − 1 intermediate disks; the anchor terminates
the cable and adds no wrap). Every function broadcasts over leading batch dimensions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "validate_friction_coefficient",
    "pinhole_positions",
    "wrap_angles",
    "slip_from_speed",
    "update_slip",
    "tension_profile",
    "anchor_tension",
]

#: Direction along which the cable reaches the base disk from the actuator (R0, +Z0).
BASE_ENTRY = np.array([0.0, 0.0, 1.0])


def validate_friction_coefficient(mu: Any, name: str = "friction_coefficient") -> np.ndarray:
    """``mu`` as a float64 array of finite values >= 0; ``ValueError`` naming ``name`` if not."""
    probe = np.asarray(mu)
    if isinstance(mu, bool) or probe.dtype.kind not in "fiu":
        raise ValueError(f"{name} must be a real number >= 0, got {mu!r}")
    arr = probe.astype(np.float64)
    if not np.isfinite(arr).all() or np.any(arr < 0.0):
        raise ValueError(f"{name} must be finite and >= 0, got {mu!r}")
    return arr


def pinhole_positions(
    centres: np.ndarray, rotations: np.ndarray, radius: float, angle: float | np.ndarray
) -> np.ndarray:
    """Pinholes (..., K, 3) m of a cable at (``radius`` m, ``angle`` rad) in K disks.

    ``centres`` (..., K, 3) m and ``rotations`` (..., K, 3, 3) are disk frames in R0 (columns:
    disk x, y axes and backbone tangent), e.g. ``PCCModel.disk_frames``; the pinhole of disk k is
    ``centre_k + R_k @ (r cos β_k, r sin β_k, 0)``. ``angle``: one β for every disk, or (K,) one
    per disk (a helical cable: ``RobotParams.cable_angles_at_disks``).
    """
    a = np.asarray(angle, dtype=np.float64)
    local = np.stack([radius * np.cos(a), radius * np.sin(a), np.zeros_like(a)], axis=-1)
    return np.asarray(centres) + np.matmul(np.asarray(rotations), local[..., None])[..., 0]


def wrap_angles(pinholes: np.ndarray, base_direction: np.ndarray | None = None) -> np.ndarray:
    """Wrap angles α (..., D) rad of a cable through pinholes (..., D + 1, 3) m, base first.

    α_0 is at the base disk, between ``base_direction`` (the direction in which the cable
    arrives from the actuator; default +Z0, :data:`BASE_ENTRY`) and the first segment; α_k
    (k ≥ 1) is at disk k, between segments k − 1 and k. Each α is in [0, π]; a straight cable
    along +Z0 has α = 0 everywhere. The anchor disk (the last pinhole) adds no angle.
    """
    p = np.asarray(pinholes, dtype=np.float64)
    if p.ndim < 2 or p.shape[-1] != 3 or p.shape[-2] < 2:
        raise ValueError(f"pinholes must have shape (..., D + 1 >= 2, 3), got {p.shape}")
    seg = np.diff(p, axis=-2)  # (..., D, 3)
    norm = np.linalg.norm(seg, axis=-1, keepdims=True)
    if np.any(norm <= 0.0):
        raise ValueError("pinholes must be distinct consecutive points (a segment has length 0)")
    u = seg / norm
    entry = BASE_ENTRY if base_direction is None else np.asarray(base_direction, np.float64)
    entry = np.broadcast_to(
        entry / np.linalg.norm(entry, axis=-1, keepdims=True), u[..., 0, :].shape
    )
    incoming = np.concatenate([entry[..., None, :], u[..., :-1, :]], axis=-2)  # (..., D, 3)
    # angle between unit vectors via atan2(|a×b|, a·b): accurate near 0 and π (arccos is not)
    cross = np.linalg.norm(np.cross(incoming, u), axis=-1)
    dot = np.einsum("...i,...i->...", incoming, u)
    return np.arctan2(cross, dot)


def slip_from_speed(speed: Any, velocity_scale: float) -> np.ndarray:
    """Memoryless slip state ``tanh(speed / velocity_scale)`` in (−1, 1).

    ``speed`` (...) m/s is the cable's sliding speed, positive when it slides towards the base
    (pulling); ``velocity_scale`` (m/s, > 0) is the speed at which friction is 76 % developed.
    """
    if not (np.isfinite(velocity_scale) and velocity_scale > 0.0):
        raise ValueError(f"velocity_scale must be finite and > 0 m/s, got {velocity_scale!r}")
    return np.tanh(np.asarray(speed, dtype=np.float64) / velocity_scale)


def update_slip(slip: Any, displacement: Any, slip_length: float) -> np.ndarray:
    """The Dahl-type slip state after the cable slides by ``displacement`` (...) m.

    Exact solution of ``ds/dx = (1 − s·sign(dx)) / slip_length`` over one step:
    ``s' = σ + (s − σ)·exp(−|dx| / slip_length)`` with σ = sign(dx) (s unchanged for dx = 0).
    ``displacement`` is positive towards the base (pulling); ``slip`` (...) is in [−1, 1];
    ``slip_length`` (m, > 0) is the sliding distance over which friction develops (1 − 1/e).
    """
    if not (np.isfinite(slip_length) and slip_length > 0.0):
        raise ValueError(f"slip_length must be finite and > 0 m, got {slip_length!r}")
    s = np.asarray(slip, dtype=np.float64)
    dx = np.asarray(displacement, dtype=np.float64)
    sigma = np.sign(dx)
    return sigma + (s - sigma) * np.exp(-np.abs(dx) / slip_length)


def tension_profile(
    actuator_tension: Any, wraps: Any, friction_coefficient: Any, slip: Any = 1.0
) -> np.ndarray:
    """Tension (..., D) N in each of a cable's D segments, base segment first.

    Args:
        actuator_tension: (...) N, the tension the actuator applies at the base.
        wraps: (..., D) rad, the wrap angles of :func:`wrap_angles`.
        friction_coefficient: μ (...) >= 0 (broadcast over the batch).
        slip: slip state s (...) in [−1, 1]: +1 pulling (tension falls towards the anchor),
            −1 releasing (it rises), |s| < 1 stick (regularised, see the module docstring).

    Returns:
        ``T_k = T_act·exp(−s·μ·Σ_{j≤k} α_j)``: segment k starts beyond disk k. With μ = 0 every
        segment carries T_act exactly.
    """
    mu = validate_friction_coefficient(friction_coefficient)
    s = np.asarray(slip, dtype=np.float64)
    if not np.isfinite(s).all() or np.any(np.abs(s) > 1.0):
        raise ValueError(f"slip must be finite and in [-1, 1], got {slip!r}")
    t = np.asarray(actuator_tension, dtype=np.float64)
    a = np.asarray(wraps, dtype=np.float64)
    if not np.isfinite(a).all() or np.any(a < 0.0):
        raise ValueError(f"wraps (wrap angles) must be finite and >= 0 rad, got {wraps!r}")
    exponent = -(s * mu)[..., None] * np.cumsum(a, axis=-1)
    return t[..., None] * np.exp(exponent)


def anchor_tension(
    actuator_tension: Any, wraps: Any, friction_coefficient: Any, slip: Any = 1.0
) -> np.ndarray:
    """Tension (...) N at the cable's anchor (its last segment), see :func:`tension_profile`."""
    return tension_profile(actuator_tension, wraps, friction_coefficient, slip)[..., -1]
