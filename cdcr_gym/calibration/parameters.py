"""The parameters a calibration can fit: names, units, scaling, bounds, and how a set of values
becomes a robot (``RobotParams``), backend keyword arguments and a frame tilt.

==================== =========== ========================== ===================================
name (aliases)       unit        scaled variable x          applies to
==================== =========== ========================== ===================================
youngs_modulus (E)   Pa          ln(E/E₀)                   ``RobotParams.youngs_modulus``
cable_radius (r)     m           (r − r₀)/1 mm              every section's ``cable_radius``
cable_angle_i        rad         offset/1°                  cable i's angle β_i (i = 1…C)
friction_coefficient —           μ/0.1                      backend ``friction_coefficient``
(mu)                                                        (physics backends)
tip_payload          kg          m/10 g                     backend ``tip_payload`` (physics)
(payload)
base_tilt_x,         rad         angle/1°                   rotation of the robot's base about
base_tilt_y (tilt)                                          X0 then Y0 (both: ``tilt``)
==================== =========== ========================== ===================================

The scaled variables are O(1) for plausible deviations, so ``least_squares`` sees a
well-conditioned problem and its finite-difference steps mean the same thing for every
parameter. ``cable_angles`` expands to every ``cable_angle_i``.

Base tilt: the robot's base frame is turned by R = Ry(b_y)·Rx(b_x) against the measurement
frame (whose Z is the nominal backbone axis and, with gravity, vertical). The predicted tips are
rotated by R; a backend that takes ``base_orientation`` also gets R, so gravity acts along the
measurement frame's −Z.
"""

from __future__ import annotations

import difflib
import inspect
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cdcr_gym.model.params import RobotParams, SectionParams

__all__ = [
    "ParameterSpec",
    "ALIASES",
    "PHYSICS_ONLY",
    "resolve_names",
    "parameter_specs",
    "robot_with",
    "tilt_matrix",
    "tilt_quaternion",
]

#: Short names accepted on the command line.
ALIASES = {
    "E": ["youngs_modulus"],
    "mu": ["friction_coefficient"],
    "payload": ["tip_payload"],
    "r": ["cable_radius"],
    "tilt": ["base_tilt_x", "base_tilt_y"],
    "base_tilt": ["base_tilt_x", "base_tilt_y"],
}
#: Parameters only a backend with that keyword argument models.
PHYSICS_ONLY = {"friction_coefficient": "friction_coefficient", "tip_payload": "tip_payload"}


@dataclass(frozen=True)
class ParameterSpec:
    """One fitted parameter: x = (value − offset)/scale, or ln(value/offset) when ``log``."""

    name: str
    unit: str
    scale: float
    offset: float
    lower: float  #: SI bounds
    upper: float
    log: bool = False

    def to_x(self, value: float) -> float:
        if self.log:
            return math.log(value / self.offset)
        return (value - self.offset) / self.scale

    def from_x(self, x: float) -> float:
        if self.log:
            return self.offset * math.exp(x)
        return self.offset + self.scale * x

    def derivative(self, x: float) -> float:
        """d value / d x at x (for the confidence intervals)."""
        return self.from_x(x) if self.log else self.scale

    def bounds_x(self) -> tuple[float, float]:
        lo = self.to_x(self.lower) if (not self.log or self.lower > 0) else -np.inf
        hi = self.to_x(self.upper) if math.isfinite(self.upper) else np.inf
        return lo, hi


def _all_names(params: RobotParams) -> list[str]:
    return (
        ["youngs_modulus", "cable_radius"]
        + [f"cable_angle_{i + 1}" for i in range(params.n_cables)]
        + ["friction_coefficient", "tip_payload", "base_tilt_x", "base_tilt_y"]
    )


def accepts(backend_class: Any, keyword: str) -> bool:
    """Whether ``backend_class``'s constructor takes ``keyword`` (None: the analytic model)."""
    if backend_class is None:
        return False
    return keyword in inspect.signature(backend_class.__init__).parameters


def resolve_names(
    names: str | list[str], params: RobotParams, backend_class: Any = None, backend_name: str = ""
) -> list[str]:
    """The canonical parameter names of a ``--fit`` list (comma-separated string or list).

    Raises:
        ValueError: naming an unknown parameter (with the accepted names and a close match),
            a duplicate, or a parameter the backend does not model (μ and payload need a
            physics backend).
    """
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    if not names:
        raise ValueError("no parameters to fit: give e.g. --fit E,mu,payload")
    known = _all_names(params)
    out: list[str] = []
    for name in names:
        expanded = ALIASES.get(name)
        if expanded is None and name == "cable_angles":
            expanded = [f"cable_angle_{i + 1}" for i in range(params.n_cables)]
        if expanded is None:
            if name not in known:
                close = difflib.get_close_matches(name, known + list(ALIASES), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ValueError(
                    f"unknown parameter {name!r}{hint}; accepted: {known + sorted(ALIASES)} "
                    "and cable_angles"
                )
            expanded = [name]
        for n in expanded:
            if n in out:
                raise ValueError(f"parameter {n!r} is given twice in the fit list {names}")
            out.append(n)
    for n in out:
        if n in PHYSICS_ONLY and not accepts(backend_class, PHYSICS_ONLY[n]):
            label = backend_name or "analytic"
            raise ValueError(
                f"parameter {n!r} cannot be fitted on the {label} backend, which does not model "
                f"it (no {PHYSICS_ONLY[n]!r} argument); use a physics backend (bullet, mujoco)"
            )
    return out


def parameter_specs(
    names: list[str], params: RobotParams, start: dict[str, float]
) -> list[ParameterSpec]:
    """Scaling and bounds of ``names`` around the robot ``params`` and the start values."""
    specs = []
    radius = max(params.cable_radii)
    for n in names:
        if n == "youngs_modulus":
            # the lowest E whose bend limit stays <= π at the largest radius allowed below
            limit = max(params.section_bend_limits)
            r_gain = (params.disk_radius * 0.999) / radius if "cable_radius" in names else 1.0
            lowest = params.youngs_modulus * limit * r_gain / math.pi * 1.001
            specs.append(
                ParameterSpec(
                    n,
                    "Pa",
                    1.0,
                    params.youngs_modulus,
                    max(0.1 * params.youngs_modulus, lowest),
                    10.0 * params.youngs_modulus,
                    log=True,
                )
            )
        elif n == "cable_radius":
            specs.append(
                ParameterSpec(n, "m", 1e-3, radius, 0.5 * radius, 0.999 * params.disk_radius)
            )
        elif n.startswith("cable_angle_"):
            specs.append(ParameterSpec(n, "rad", math.radians(1.0), 0.0, -math.pi / 6, math.pi / 6))
        elif n == "friction_coefficient":
            specs.append(ParameterSpec(n, "", 0.1, 0.0, 0.0, 1.0))
        elif n == "tip_payload":
            specs.append(ParameterSpec(n, "kg", 0.01, 0.0, 0.0, np.inf))
        elif n in ("base_tilt_x", "base_tilt_y"):
            specs.append(ParameterSpec(n, "rad", math.radians(1.0), 0.0, -math.pi / 6, math.pi / 6))
        else:  # pragma: no cover - resolve_names guards
            raise ValueError(f"unknown parameter {n!r}")
    return specs


def robot_with(params: RobotParams, values: dict[str, float]) -> RobotParams:
    """``params`` with the robot parameters among ``values`` (SI) applied.

    ``cable_radius`` is the radius of the cables of the section with the largest radius; every
    section's radius moves by the same offset (one section: it is the section's radius).
    """
    offset = values.get("cable_radius", max(params.cable_radii)) - max(params.cable_radii)
    sections = []
    k = 0
    for s in params.sections:
        angles = []
        for a in s.cable_angles:
            k += 1
            angles.append(a + values.get(f"cable_angle_{k}", 0.0))
        sections.append(
            SectionParams(
                length=s.length,
                n_disks=s.n_disks,
                cable_radius=s.cable_radius + offset,
                cable_angles=tuple(angles),
            )
        )
    return RobotParams(
        sections=tuple(sections),
        youngs_modulus=values.get("youngs_modulus", params.youngs_modulus),
        backbone_diameter=params.backbone_diameter,
        max_tension=params.max_tension,
        backbone_density=params.backbone_density,
        disk_mass=params.disk_mass,
        disk_radius=params.disk_radius,
        disk_thickness=params.disk_thickness,
    )


def tilt_matrix(values: dict[str, float]) -> np.ndarray:
    """R = Ry(b_y)·Rx(b_x) (3, 3) of the base tilt in ``values`` (identity without tilt)."""
    bx = values.get("base_tilt_x", 0.0)
    by = values.get("base_tilt_y", 0.0)
    cx, sx, cy, sy = math.cos(bx), math.sin(bx), math.cos(by), math.sin(by)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    return ry @ rx


def tilt_quaternion(values: dict[str, float]) -> tuple[float, float, float, float]:
    """The base tilt as a unit quaternion (x, y, z, w) (pybullet's ``base_orientation``)."""
    bx = values.get("base_tilt_x", 0.0)
    by = values.get("base_tilt_y", 0.0)
    qx = np.array([math.sin(bx / 2), 0.0, 0.0, math.cos(bx / 2)])
    qy = np.array([0.0, math.sin(by / 2), 0.0, math.cos(by / 2)])
    # q = qy ⊗ qx (Hamilton product, vector part first)
    v1, w1, v2, w2 = qy[:3], qy[3], qx[:3], qx[3]
    v = w1 * v2 + w2 * v1 + np.cross(v1, v2)
    w = w1 * w2 - float(v1 @ v2)
    q = np.append(v, w)
    q /= np.linalg.norm(q)
    return tuple(float(c) for c in q)  # type: ignore[return-value]
