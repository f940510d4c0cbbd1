"""The parameters a calibration can fit: names, units, scaling, bounds, and how a set of values
becomes a robot (``RobotParams``), backend keyword arguments and a frame tilt.

==================== =========== ========================== ===================================
name (aliases)       unit        scaled variable x          applies to
==================== =========== ========================== ===================================
youngs_modulus (E)   Pa          ln(E/E₀)                   ``RobotParams.youngs_modulus``
cable_radius (r)     m           (r − r₀)/1 mm              every section's ``cable_radius``
cable_angle_i        rad         offset/1°                  cable i's angle β_i (i = 1…C)
cable_pitch          rad/m       p/(0.1 rad/m)              ``RobotParams.cable_pitch``: the
                                                            cables wound helically
friction_coefficient —           μ/0.1                      backend ``friction_coefficient``
(mu)                                                        (physics backends)
tip_payload          kg          m/10 g                     backend ``tip_payload`` (physics)
(payload)
backbone_friction    N·m         M_f/1 mN·m                 backend ``backbone_friction``
                                                            (MuJoCo)
base_tilt_x,         rad         angle/1°                   rotation of the robot's base about
base_tilt_y (tilt)                                          X0 then Y0 (both: ``tilt``)
==================== =========== ========================== ===================================

The scaled variables are O(1) for plausible deviations, so ``least_squares`` sees a
well-conditioned problem and its finite-difference steps mean the same thing for every
parameter. ``cable_angles`` expands to every ``cable_angle_i``.

Names for robots driven by tendon displacement (the ``ccka`` backend on displacement data, or
on tension data: the same geometry, the tensions given), S sections, C tendons:

====================================== ===== ====================== =============================
name (aliases)                         unit  scaled variable x      applies to
====================================== ===== ====================== =============================
base_x, base_y, base_z                 m     offset/1 mm            robot base origin in the
(``base_translation``)                                              measurement frame
base_yaw                               rad   angle/1°               rotation about the measurement
                                                                    Z (with ``tilt``:
                                                                    ``base_rotation``)
marker_offset (``marker``)             m     offset/1 mm            marker along the tip tangent
length_s<j> (``lengths``)              m     (ℓ − ℓ₀)/1 mm          section j's length
cable_radius_s<j> (``cable_radii``)    m     (r − r₀)/(0.1·r₀)      section j's routing radius
section_angle_s<j> (``section_angles``) rad  offset/1°              every tendon angle of
                                                                    section j
tendon_stiffness (``k``),              N/m   ln(k/k₀)               all tendons / section j's /
tendon_stiffness_s<j> (``k_sections``),                             tendon i's k (the drive law
tendon_stiffness_<i> (``k_tendons``)                                T = T0 + k·(d − s))
tendon_pretension (``T0``), …_s<j>     N     (T0 − T0₀)/1 N         likewise T0 (≥ 0, as the
(``T0_sections``), …_<i>                                            robot's ``tendon_pretension``)
(``T0_tendons``)
base_compliance                        m/N   c/(1e-5 m/N)           the base's give under the
                                                                    total tendon load (≥ 0,
                                                                    ``RobotParams.base_compliance``)
drive_backlash                         m     w/(0.1 mm)             the play between each
                                                                    drive's command and its
                                                                    tendon (≥ 0, rows in order:
                                                                    ``calibration.backlash``)
drive_softening                        1/m   σ/(10 /m)              the rate at which each
                                                                    drive's pull saturates (≥ 0;
                                                                    a drive at y > 0 pulls by
                                                                    tanh(σy)/σ:
                                                                    ``model.drive_softening``)
====================================== ===== ====================== =============================

``base_frame`` = the translation, the tilt and the yaw. Gravity and payload are not modelled by
the CCKA model (a physics backend's ``tip_payload`` stays physics-only).

Ill-posed pairs (:func:`pin_ill_posed`): a common offset of every tendon angle equals a base yaw
(without tilt), so with ``base_yaw`` fitted and every tendon's angle free (all ``cable_angle_i``
or all ``section_angle_s<j>``) the first of them is pinned at its start; E, every k and every T0
scaled together leave every shape unchanged, so with all three free E is pinned. A name and an
alias covering the same quantity (``tendon_stiffness`` and ``tendon_stiffness_s1``,
``section_angle_s1`` and ``cable_angle_1``) are an error.

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
    "expand_names",
    "check_start",
    "pin_ill_posed",
    "drive_only",
]

#: Short names accepted on the command line.
ALIASES = {
    "E": ["youngs_modulus"],
    "mu": ["friction_coefficient"],
    "payload": ["tip_payload"],
    "r": ["cable_radius"],
    "tilt": ["base_tilt_x", "base_tilt_y"],
    "base_tilt": ["base_tilt_x", "base_tilt_y"],
    "k": ["tendon_stiffness"],
    "T0": ["tendon_pretension"],
    "marker": ["marker_offset"],
    "base_translation": ["base_x", "base_y", "base_z"],
    "base_rotation": ["base_tilt_x", "base_tilt_y", "base_yaw"],
    "base_frame": ["base_x", "base_y", "base_z", "base_tilt_x", "base_tilt_y", "base_yaw"],
}
#: Parameters only a backend with that keyword argument models.
PHYSICS_ONLY = {
    "friction_coefficient": "friction_coefficient",
    "tip_payload": "tip_payload",
    "backbone_friction": "backbone_friction",
}


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
        + ["cable_pitch"]
        + ["friction_coefficient", "tip_payload", "backbone_friction", "base_tilt_x", "base_tilt_y"]
        + DRIVE_COMMON
        + _per(params)
    )


#: Names of the CCKA model with a base frame and a tendon drive (module docstring).
DRIVE_COMMON = [
    "base_x",
    "base_y",
    "base_z",
    "base_yaw",
    "marker_offset",
    "tendon_stiffness",
    "tendon_pretension",
    "base_compliance",
    "drive_backlash",
    "drive_softening",
]


def _per(params: RobotParams) -> list[str]:
    """The per-section and per-tendon names of ``params``."""
    s, c = params.n_sections, params.n_cables
    out = []
    for stem in ("length_s", "cable_radius_s", "section_angle_s"):
        out += [f"{stem}{j + 1}" for j in range(s)]
    for stem in ("tendon_stiffness", "tendon_pretension"):
        out += [f"{stem}_s{j + 1}" for j in range(s)] + [f"{stem}_{i + 1}" for i in range(c)]
    return out


def drive_only(name: str) -> bool:
    """Whether ``name`` needs the CCKA drive model (not the tension-only analytic replay)."""
    return name in DRIVE_COMMON or any(
        name.startswith(p) for p in ("length_s", "cable_radius_s", "section_angle_s", "tendon_")
    )


def _expand_alias(name: str, params: RobotParams) -> list[str] | None:
    s, c = params.n_sections, params.n_cables
    table = {
        "cable_angles": [f"cable_angle_{i + 1}" for i in range(c)],
        "lengths": [f"length_s{j + 1}" for j in range(s)],
        "cable_radii": [f"cable_radius_s{j + 1}" for j in range(s)],
        "section_angles": [f"section_angle_s{j + 1}" for j in range(s)],
        "k_sections": [f"tendon_stiffness_s{j + 1}" for j in range(s)],
        "k_tendons": [f"tendon_stiffness_{i + 1}" for i in range(c)],
        "T0_sections": [f"tendon_pretension_s{j + 1}" for j in range(s)],
        "T0_tendons": [f"tendon_pretension_{i + 1}" for i in range(c)],
    }
    return ALIASES.get(name) or table.get(name)


#: Aliases that expand per robot (listed in the help).
ROBOT_ALIASES = [
    "cable_angles",
    "lengths",
    "cable_radii",
    "section_angles",
    "k_sections",
    "k_tendons",
    "T0_sections",
    "T0_tendons",
]


def _covers(name: str, params: RobotParams) -> set[tuple[str, int]]:
    """The (quantity, tendon or section) a fitted name sets, to find overlaps."""
    c = params.n_cables
    owner = params.cable_section
    for q in ("tendon_stiffness", "tendon_pretension"):
        if name == q:
            return {(q, i) for i in range(c)}
        if name.startswith(q + "_s"):
            j = int(name[len(q) + 2 :]) - 1
            return {(q, i) for i in range(c) if owner[i] == j}
        if name.startswith(q + "_"):
            return {(q, int(name[len(q) + 1 :]) - 1)}
    if name.startswith("section_angle_s"):
        j = int(name[len("section_angle_s") :]) - 1
        return {("angle", i) for i in range(c) if owner[i] == j}
    if name.startswith("cable_angle_"):
        return {("angle", int(name[len("cable_angle_") :]) - 1)}
    if name == "cable_radius":
        return {("radius", j) for j in range(params.n_sections)}
    if name.startswith("cable_radius_s"):
        return {("radius", int(name[len("cable_radius_s") :]) - 1)}
    return {(name, 0)}


def pin_ill_posed(names: list[str], params: RobotParams) -> tuple[list[str], list[str]]:
    """``names`` without the parameters pinned for ill-posed pairs, and notes saying which
    (module docstring)."""
    notes = []
    out = list(names)
    covered: set[tuple[str, int]] = set()
    for n in out:
        covered |= _covers(n, params)
    c = params.n_cables
    if "base_yaw" in out and all(("angle", i) in covered for i in range(c)):
        first = next(n for n in out if ("angle", 0) in _covers(n, params))
        out.remove(first)
        notes.append(
            f"pinned {first} at its start: a common offset of every tendon angle equals the base "
            "yaw (base_yaw and every tendon angle were free)"
        )
    full = all(
        (q, i) in covered for q in ("tendon_stiffness", "tendon_pretension") for i in range(c)
    )
    if "youngs_modulus" in out and full:
        out.remove("youngs_modulus")
        notes.append(
            "pinned youngs_modulus at its start: E, every tendon stiffness and every pretension "
            "scaled together leave every shape unchanged"
        )
    return out, notes


def accepts(backend_class: Any, keyword: str) -> bool:
    """Whether ``backend_class``'s constructor takes ``keyword`` (None: the analytic model)."""
    if backend_class is None:
        return False
    return keyword in inspect.signature(backend_class.__init__).parameters


def resolve_names(
    names: str | list[str],
    params: RobotParams,
    backend_class: Any = None,
    backend_name: str = "",
    *,
    displacement: bool = False,
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
    out = expand_names(names, params)
    covered: dict[tuple[str, int], str] = {}
    for n in out:
        for key in _covers(n, params):
            if key in covered:
                raise ValueError(
                    f"parameters {covered[key]!r} and {n!r} both set the same quantity "
                    f"({key[0]} of tendon/section {key[1] + 1}); fit one of them"
                )
            covered[key] = n
    for n in out:
        if backend_class is not None and displacement:
            from cdcr_gym.calibration.physics import physics_name

            if not physics_name(n):
                raise ValueError(
                    f"parameter {n!r} cannot be fitted by the {backend_name or 'physics'} "
                    "backend's displacement replay (it keeps the robot's geometry: start from a "
                    "--backend ccka fit's params.yaml that holds the fitted lengths, radii, "
                    "tendon angles and cable pitch)"
                )
            if n not in PHYSICS_ONLY or accepts(backend_class, PHYSICS_ONLY[n]):
                continue
        if backend_class is not None and drive_only(n):
            raise ValueError(
                f"parameter {n!r} belongs to the CCKA drive model; fit it with --backend ccka "
                f"(the {backend_name or 'physics'} backend fits it on displacement data only)"
            )
        if n in PHYSICS_ONLY and not accepts(backend_class, PHYSICS_ONLY[n]):
            label = backend_name or "analytic"
            which = "mujoco" if n == "backbone_friction" else "bullet, mujoco"
            raise ValueError(
                f"parameter {n!r} cannot be fitted on the {label} backend, which does not model "
                f"it (no {PHYSICS_ONLY[n]!r} argument); use a physics backend ({which})"
            )
    return out


def expand_names(names: str | list[str], params: RobotParams) -> list[str]:
    """Canonical names of a list of names and aliases (unknown name or duplicate: ValueError)."""
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    known = _all_names(params)
    out: list[str] = []
    for name in names:
        expanded = _expand_alias(name, params)
        if expanded is None:
            if name not in known:
                accepted = known + sorted(ALIASES) + ROBOT_ALIASES
                close = difflib.get_close_matches(name, accepted, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ValueError(f"unknown parameter {name!r}{hint}; accepted: {accepted}")
            expanded = [name]
        for n in expanded:
            if n in out:
                raise ValueError(f"parameter {n!r} is given twice in the fit list {names}")
            out.append(n)
    return out


#: Names whose values must be >= 0 (a --start value is checked).
NON_NEGATIVE = (
    "friction_coefficient",
    "tip_payload",
    "base_compliance",
    "backbone_friction",
    "drive_backlash",
    "drive_softening",
)
#: Names whose values must be > 0 (a --start value is checked).
POSITIVE = ("youngs_modulus", "cable_radius", "length_s", "tendon_stiffness")


def check_start(name: str, value: float) -> None:
    """ValueError if ``value`` is not a valid start value of parameter ``name``."""
    if not np.isfinite(value):
        raise ValueError(f"start value of {name!r} must be finite, got {value!r}")
    if name.startswith(POSITIVE) and value <= 0.0:
        raise ValueError(f"start value of {name!r} must be > 0, got {value!r}")
    if name in NON_NEGATIVE and value < 0.0:
        raise ValueError(f"start value of {name!r} must be >= 0, got {value!r}")


def parameter_specs(
    names: list[str], params: RobotParams, start: dict[str, float], *, bend_limit: bool = True
) -> list[ParameterSpec]:
    """Scaling and bounds of ``names`` around the robot ``params`` and the start values.

    ``bend_limit``: E's lower bound keeps every section's bend within π at ``max_tension``
    (tension data); False (the drive model, whose tensions come from the law) allows E/10."""
    specs = []
    radius = max(params.cable_radii)
    for n in names:
        if n == "youngs_modulus":
            # the lowest E whose bend limit stays <= π at the largest radius allowed below
            limit = max(params.section_bend_limits)
            r_gain = (params.disk_radius * 0.999) / radius if "cable_radius" in names else 1.0
            lowest = params.youngs_modulus * limit * r_gain / math.pi * 1.001
            if not bend_limit:
                lowest = 0.0
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
        elif n == "cable_pitch":  # at most half a turn per section
            bound = math.pi / max(params.section_lengths)
            specs.append(ParameterSpec(n, "rad/m", 0.1, 0.0, -bound, bound))
        elif n == "friction_coefficient":
            specs.append(ParameterSpec(n, "", 0.1, 0.0, 0.0, 1.0))
        elif n == "tip_payload":
            specs.append(ParameterSpec(n, "kg", 0.01, 0.0, 0.0, np.inf))
        elif n == "backbone_friction":
            specs.append(ParameterSpec(n, "N·m", 1e-3, 0.0, 0.0, np.inf))
        elif n in ("base_tilt_x", "base_tilt_y"):
            specs.append(ParameterSpec(n, "rad", math.radians(1.0), 0.0, -math.pi / 6, math.pi / 6))
        elif n in ("base_x", "base_y", "base_z", "marker_offset"):
            specs.append(ParameterSpec(n, "m", 1e-3, start.get(n, 0.0), -np.inf, np.inf))
        elif n == "base_yaw" or n.startswith("section_angle_s"):
            specs.append(ParameterSpec(n, "rad", math.radians(1.0), 0.0, -math.pi, math.pi))
        elif n.startswith("length_s"):
            ell = params.sections[int(n[len("length_s") :]) - 1].length
            specs.append(ParameterSpec(n, "m", 1e-3, ell, 0.5 * ell, 1.5 * ell))
        elif n.startswith("cable_radius_s"):
            r = params.sections[int(n[len("cable_radius_s") :]) - 1].cable_radius
            specs.append(ParameterSpec(n, "m", 0.1 * r, r, 0.5 * r, 0.999 * params.disk_radius))
        elif n.startswith("tendon_stiffness"):
            k0 = start.get(n, 1.0)
            specs.append(ParameterSpec(n, "N/m", 1.0, k0, 1e-3 * k0, 1e3 * k0, log=True))
        elif n.startswith("tendon_pretension"):
            specs.append(ParameterSpec(n, "N", 1.0, 0.0, 0.0, np.inf))
        elif n == "base_compliance":
            specs.append(ParameterSpec(n, "m/N", 1e-5, 0.0, 0.0, np.inf))
        elif n == "drive_backlash":
            specs.append(ParameterSpec(n, "m", 1e-4, 0.0, 0.0, np.inf))
        elif n == "drive_softening":
            specs.append(ParameterSpec(n, "1/m", 10.0, 0.0, 0.0, np.inf))
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
        cable_pitch=values.get("cable_pitch", params.cable_pitch),
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
