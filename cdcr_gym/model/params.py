"""The robot description: sections of a cable-driven continuum robot, in SI units.

A robot is a sequence of :class:`SectionParams` stacked from the base (docs/model.md). Section j has a
length ℓ_j, ``n_disks`` spacer disks (evenly spaced, the last at the section's end) and its own
cables, which terminate at that last disk. A cable of section j runs through every disk of
sections 1…j at its radius r and its angle β from the disk's x axis: parallel to the backbone,
or wound helically about it when the robot has a ``cable_pitch`` (the angle at arc length z is
β + pitch·z). :class:`RobotParams` adds the backbone material,
the masses and the tension limit shared by all cables.

Cable order (actions, tensions, cable lengths): section by section, proximal first; within a
section, the order of its ``cable_angles``.

The paper's robot (one section, 641 mm, 9 disks, r = 29 mm, cables at 0°/120°/240°) is the
default, and the single-section keywords ``RobotParams(length=..., n_disks=..., cable_radius=...)``
build a one-section robot as they always did.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from cdcr_gym.model.yaml_io import dump_yaml, load_yaml, number

__all__ = [
    "SectionParams",
    "RobotParams",
    "CABLE_ANGLES",
    "PRESETS",
    "STANDARD_GRAVITY",
    "FTDCR_V4_SECTION_OFFSETS",
    "FTDCR_V4_TENDON_ANGLE_DELTAS",
    "FTDCR_V4_PRETENSION",
    "params_to_dict",
    "params_from_dict",
]

#: Angular positions β_i of the paper's cables 1, 2, 3, from +X0 about +Z0 (rad).
CABLE_ANGLES: tuple[float, float, float] = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)

#: Standard gravity (m/s²), the one value of g in the package (along −Z_world where enabled).
STANDARD_GRAVITY = 9.81


def _real(owner: str, name: str, value: Any, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{owner}.{name} must be a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0.0):
        rule = "finite and > 0 (SI units)" if positive else "finite"
        raise ValueError(f"{owner}.{name} must be {rule}, got {value!r}")
    return value


def _count(owner: str, name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{owner}.{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _stiffness(owner: str, name: str, value: Any) -> float:
    """A tendon stiffness (N/m): > 0, ``inf`` allowed (inextensible)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{owner}.{name} must be a real number (N/m), got {value!r}")
    value = float(value)
    if math.isnan(value) or value <= 0.0:
        raise ValueError(f"{owner}.{name} must be > 0 N/m (inf: inextensible), got {value!r}")
    return value


def _pretension(owner: str, name: str, value: Any) -> float:
    """A tendon pretension (N): finite and >= 0."""
    value = _real(owner, name, value, positive=False)
    if value < 0.0:
        raise ValueError(f"{owner}.{name} must be >= 0 N, got {value!r}")
    return value


def _per_cable(
    owner: str, name: str, value: Any, n_cables: int, check
) -> float | tuple[float, ...]:
    """A scalar (every cable) or one value per cable (cable order), checked by ``check``."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{owner}.{name} must be a number or one number per cable, got {value!r}")
    if isinstance(value, (Sequence, np.ndarray)):
        values = tuple(check(owner, name, v) for v in value)
        if len(values) != n_cables:
            raise ValueError(
                f"{owner}.{name} needs one value per cable ({n_cables}) or a scalar, "
                f"got {len(values)}: {value!r}"
            )
        return values
    return check(owner, name, value)


def _displacement_range(owner: str, value: Any) -> tuple[float, float]:
    name = "displacement_range"
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{owner}.{name} must be a pair (d_min, d_max) in m, got {value!r}")
    if len(value) != 2:
        raise ValueError(f"{owner}.{name} must be a pair (d_min, d_max) in m, got {value!r}")
    low, high = (_real(owner, name, v, positive=False) for v in value)
    if not low < high:
        raise ValueError(f"{owner}.{name} must have d_min < d_max (m), got {value!r}")
    return (low, high)


@dataclass(frozen=True)
class SectionParams:
    """One constant-curvature section and the cables that end at its last disk (SI units).

    Attributes:
        length: backbone length ℓ_j of the section (m), inextensible.
        n_disks: spacer disks of the section, evenly spaced, the last at the section's end
            (the base disk at s = 0, or the previous section's last disk, comes in addition).
        cable_radius: distance r of this section's cables from the backbone axis (m).
        cable_angles: angles β (rad) of this section's cables, from the disk's x axis about the
            backbone (+Z0 at the base). At least 3, distinct, and not all within a half-plane
            (every bending direction must be reachable by pulling: the largest angular gap
            between neighbouring cables is < π).

    Raises:
        ValueError: naming the field and the offending value.
    """

    length: float = 0.641  # the paper's Table 1
    n_disks: int = 9
    cable_radius: float = 0.029
    cable_angles: tuple[float, ...] = CABLE_ANGLES

    def __post_init__(self) -> None:
        owner = "SectionParams"
        object.__setattr__(self, "length", _real(owner, "length", self.length))
        object.__setattr__(self, "n_disks", _count(owner, "n_disks", self.n_disks, 1))
        object.__setattr__(self, "cable_radius", _real(owner, "cable_radius", self.cable_radius))
        angles = self.cable_angles
        if isinstance(angles, (str, bytes)) or not isinstance(angles, (Sequence, np.ndarray)):
            raise ValueError(
                f"{owner}.cable_angles must be a sequence of angles (rad), got {angles!r}"
            )
        angles = tuple(_real(owner, "cable_angles", a, positive=False) for a in angles)
        if len(angles) < 3:
            raise ValueError(
                f"{owner}.cable_angles needs at least 3 cables to bend in every direction, "
                f"got {len(angles)}: {angles!r}"
            )
        wrapped = np.sort(np.mod(np.asarray(angles), 2.0 * math.pi))
        gaps = np.diff(np.concatenate([wrapped, wrapped[:1] + 2.0 * math.pi]))
        if np.min(gaps) < 1e-9:
            raise ValueError(f"{owner}.cable_angles must be distinct (mod 2π), got {angles!r}")
        if np.max(gaps) >= math.pi - 1e-9:
            raise ValueError(
                f"{owner}.cable_angles {angles!r} leave a gap of {math.degrees(np.max(gaps)):.1f}° "
                f">= 180° between neighbouring cables: some bending directions cannot be pulled"
            )
        object.__setattr__(self, "cable_angles", angles)

    @property
    def n_cables(self) -> int:
        """Number of cables ending in this section."""
        return len(self.cable_angles)

    @property
    def disk_spacing(self) -> float:
        """Arc length between consecutive disks of this section (m)."""
        return self.length / self.n_disks


_SINGLE_SECTION_KEYS = ("length", "n_disks", "cable_radius")
#: The drive description (docs/robots.md, tendon drives): scalars or per-cable tuples, and a pair.
_DRIVE_KEYS = ("tendon_stiffness", "tendon_pretension", "displacement_range")


@dataclass(frozen=True)
class RobotParams:
    """A cable-driven continuum robot of one or more sections, in SI units (m, kg, Pa, N).

    Defaults are the paper's Table 1 (one section: ℓ = 641 mm, d = 5 mm, r = 29 mm, 9 spacer
    disks, cables at 0°/120°/240°), with one correction: the paper prints E = 35 MPa, which is a
    unit slip. With d = 5 mm the second moment of area is I = πd⁴/64 ≈ 3.07e-11 m⁴, so
    EI(35 MPa) ≈ 1.07e-3 N·m² and a pure moment of 80 N × 0.029 m would bend the rod through
    θ = T·r·ℓ/EI ≈ 1 390 rad (≈ 80 000°). With E = 35 GPa (a glass-fibre composite) the same
    load gives θ ≈ 1.39 rad ≈ 79°, consistent with the 0–80 N range the paper applies. We
    therefore use 35 GPa.

    Masses are not in the paper; the defaults are plausible documented choices: a glass-fibre
    composite rod of density 1 900 kg/m³ (≈ 0.037 kg/m for d = 5 mm) and 10 g spacer disks.

    Two ways to describe the geometry:

    * ``sections=(SectionParams(...), ...)``: any number of sections (proximal first);
    * the single-section keywords ``length``, ``n_disks``, ``cable_radius`` (cables at
      0°/120°/240°), each defaulting to the paper's value.

    After construction ``length`` is the total backbone length, ``n_disks`` the total number of
    spacer disks, and ``cable_radius`` the routing radius shared by all cables (``None`` if the
    cables sit at different radii). With one section, single-section keywords given beside
    ``sections`` override that section's values (so ``dataclasses.replace(p, n_disks=5)``
    works); with several they must agree with the sections.

    Bending limit: every section's bend θ_j must stay ≤ π for all tensions in
    [0, max_tension] (the model, the observation bounds and the physics backend assume it).
    Parameters that allow more (a soft backbone, a high tension limit) are rejected with a
    ``ValueError`` that gives the reachable bend; see :attr:`section_bend_limits`.

    Tendon drive (:mod:`cdcr_gym.model.tendons`; docs/robots.md): each tendon is wound on a
    position-controlled drive; a commanded displacement d (m, positive = pulled in) gives the
    tension T = clip(T0 + k·(d − s), 0, max_tension), s the tendon's geometric shortening. The
    paper's robot gets k = 2·10⁴ N/m: a 0.5 mm stranded steel rope (effective E ≈ 100 GPa,
    EA ≈ 2·10⁴ N) over ≈ 0.8 m from drive to anchor is ≈ 2.5·10⁴ N/m alone, and the spool/drive
    in series lowers it; T0 = 2 N (2.5 % of the limit) keeps idle tendons taut. Its range
    ±45 mm reaches the tension limit: one cable bent to the 79° limit shortens by r·θ ≈ 40 mm and
    stretches by 80 N / k = 4 mm (so +45 mm saturates), and the opposite cable lengthens by up to
    r·θ ≈ 40 mm, which the drive must pay out (−45 mm releases it).

    Attributes:
        sections: the sections, proximal first (a tuple of :class:`SectionParams`).
        length: total backbone length (m); with no ``sections``, the one section's length.
        n_disks: total spacer disks; with no ``sections``, the one section's disks.
        cable_radius: the cables' common radius (m); with no ``sections``, the one section's.
        backbone_diameter: backbone rod diameter d (m), solid circular section.
        youngs_modulus: Young's modulus E of the backbone (Pa).
        max_tension: cable tension limit (N); tensions live in [0, max_tension].
        backbone_density: volumetric density of the backbone rod (kg/m³).
        disk_mass: mass of one spacer disk (kg).
        disk_radius: outer radius of a spacer disk (m); used for inertia and drawing.
        disk_thickness: thickness of a spacer disk along the backbone (m).
        tendon_stiffness: k, stiffness of tendon + drive (N/m), > 0 (``inf`` = inextensible):
            one number for every cable, or a tuple of one per cable (cable order).
        tendon_pretension: T0, tension at zero displacement on the straight robot (N), ≥ 0:
            a number or a tuple of one per cable.
        displacement_range: ``(d_min, d_max)`` (m), d_min < d_max: the displacements a
            normalised command a ∈ [−1, 1] maps to (linearly, a = −1 → d_min).
        base_compliance: c (m/N), ≥ 0: the robot's base (its mount, the backbone's clamp and
            axial compression) gives way under the total tendon load, so every tendon's drive
            loses c·(ΣT − ΣT0) of its pull (:mod:`cdcr_gym.model.tendons`). 0 = a rigid base.
        cable_pitch: p (rad/m), finite, either sign: helical routing. Every cable winds about
            the backbone: at arc length z from the base its pinholes sit at the angle β + p·z
            (``cable_angles`` are the angles at the base disk). 0 = cables parallel to the
            backbone. The constant-curvature model sees cable i in section j at its angle at the
            section's middle, with its radius scaled by sinc(p·ℓ_j/2), the mean of the helix
            over the section (:meth:`section_cable_vectors`).

    Raises:
        ValueError: naming the field and the offending value, for any non-finite or
            non-positive physical quantity, ``n_disks < 1``, ``disk_radius <= cable radius``,
            inconsistent single-section keywords, or a section that can bend beyond π.
    """

    # None at construction means "derive": after __post_init__ sections, length and n_disks are
    # always set (typed as such), cable_radius is None only for cables at different radii.
    sections: tuple[SectionParams, ...] = None  # type: ignore[assignment]
    length: float = None  # type: ignore[assignment]
    n_disks: int = None  # type: ignore[assignment]
    cable_radius: float | None = None
    backbone_diameter: float = 0.005
    youngs_modulus: float = 35e9
    max_tension: float = 80.0
    backbone_density: float = 1900.0
    disk_mass: float = 0.010
    disk_radius: float = 0.035
    disk_thickness: float = 0.003
    tendon_stiffness: float | tuple[float, ...] = 2.0e4
    tendon_pretension: float | tuple[float, ...] = 2.0
    displacement_range: tuple[float, float] = (-0.045, 0.045)
    base_compliance: float = 0.0
    cable_pitch: float = 0.0

    def __post_init__(self) -> None:
        owner = "RobotParams"
        sections = self.sections
        given_sections = sections is not None
        if sections is None:
            paper = SectionParams()  # the paper's section (Table 1)
            section = SectionParams(
                length=paper.length if self.length is None else _real(owner, "length", self.length),
                n_disks=paper.n_disks
                if self.n_disks is None
                else _count(owner, "n_disks", self.n_disks, 1),
                cable_radius=paper.cable_radius
                if self.cable_radius is None
                else _real(owner, "cable_radius", self.cable_radius),
            )
            sections = (section,)
        else:
            if isinstance(sections, SectionParams):
                sections = (sections,)
            if isinstance(sections, (str, bytes)) or not isinstance(sections, Sequence):
                raise ValueError(
                    f"{owner}.sections must be a sequence of SectionParams, got {sections!r}"
                )
            sections = tuple(sections)
            if not sections:
                raise ValueError(f"{owner}.sections must hold at least one section, got ()")
            for k, s in enumerate(sections):
                if not isinstance(s, SectionParams):
                    raise ValueError(f"{owner}.sections[{k}] must be a SectionParams, got {s!r}")
        if given_sections and len(sections) == 1:
            # one section: the single-section keywords override it (so dataclasses.replace works)
            overrides = {
                k: getattr(self, k)
                for k in _SINGLE_SECTION_KEYS
                if getattr(self, k) is not None and getattr(self, k) != getattr(sections[0], k)
            }
            if overrides:
                sections = (replace(sections[0], **overrides),)
        object.__setattr__(self, "sections", sections)
        derived = {
            "length": math.fsum(s.length for s in sections),
            "n_disks": sum(s.n_disks for s in sections),
            "cable_radius": _common_radius(sections),
        }
        for key in _SINGLE_SECTION_KEYS:
            given = getattr(self, key)
            if given_sections and given is not None and given != derived[key]:
                raise ValueError(
                    f"{owner}.{key}={given!r} disagrees with the sections (which give "
                    f"{derived[key]!r}); describe the geometry by `sections` only"
                )
            object.__setattr__(self, key, derived[key])
        for f in fields(self):
            if f.name in ("sections",) + _SINGLE_SECTION_KEYS + _DRIVE_KEYS:
                continue
            positive = f.name not in ("base_compliance", "cable_pitch")
            value = _real(owner, f.name, getattr(self, f.name), positive=positive)
            if value < 0.0 and f.name == "base_compliance":
                raise ValueError(f"{owner}.{f.name} must be >= 0 (m/N), got {value!r}")
            object.__setattr__(self, f.name, value)
        n_cables = sum(s.n_cables for s in sections)
        object.__setattr__(
            self,
            "tendon_stiffness",
            _per_cable(owner, "tendon_stiffness", self.tendon_stiffness, n_cables, _stiffness),
        )
        object.__setattr__(
            self,
            "tendon_pretension",
            _per_cable(owner, "tendon_pretension", self.tendon_pretension, n_cables, _pretension),
        )
        object.__setattr__(
            self, "displacement_range", _displacement_range(owner, self.displacement_range)
        )
        largest_radius = max(max(s.cable_radius for s in sections), 0.0)
        if self.disk_radius <= largest_radius:
            raise ValueError(
                f"{owner}.disk_radius ({self.disk_radius!r} m) must exceed the cable radius "
                f"({largest_radius!r} m): the pinholes sit on the disks"
            )
        limits = self.section_bend_limits
        for j, limit in enumerate(limits):
            if limit > math.pi * (1.0 + 1e-12):
                raise ValueError(
                    f"{owner}.sections[{j}] can bend to θ = {math.degrees(limit):.1f}° > 180° "
                    f"with tensions in [0, max_tension={self.max_tension!r}] N "
                    f"(youngs_modulus={self.youngs_modulus!r} Pa, backbone_diameter="
                    f"{self.backbone_diameter!r} m); the constant-curvature model and the "
                    f"observation bounds need θ <= 180°: lower max_tension to "
                    f"<= {self.max_tension * math.pi / limit:.6g} N or stiffen the backbone"
                )

    # -- presets -------------------------------------------------------------------------------
    @classmethod
    def preset(cls, name: str, **overrides: Any) -> RobotParams:
        """A named robot (see :data:`PRESETS`), with optional field ``overrides``.

        ``RobotParams.preset("paper")`` equals ``RobotParams()``; ``"tdcr2"`` is the two-section
        reference robot of Rao et al. 2021; ``"ftdcr_v4"`` the three-section real robot whose
        recordings are in ``data/real/ftdcr_v4/``.

        Raises:
            ValueError: for an unknown name (listing the known ones).
        """
        if not isinstance(name, str) or name not in PRESETS:
            raise ValueError(f"robot must be one of {sorted(PRESETS)}, got {name!r}")
        return replace(PRESETS[name], **overrides) if overrides else PRESETS[name]

    # -- YAML (format: cdcr_gym.model.params_yaml) ---------------------------------------------
    def to_yaml(self, path: Any = None) -> str:
        """This robot as YAML text (SI units, exact floats); also written to ``path`` if given.

        ``RobotParams.from_yaml(p.to_yaml()) == p``. Format: :mod:`cdcr_gym.model.params_yaml`.
        """
        text = dump_yaml(params_to_dict(self))
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_yaml(cls, source: Any) -> RobotParams:
        """The robot of a YAML file (a path) or text (:meth:`to_yaml`, or a file written by
        ``cdcr-gym calibrate``, whose robot sits under ``robot:``). Needs PyYAML.

        Raises:
            ValueError: naming the key, for unknown or duplicate keys, a section of the wrong
                type, or invalid values.
        """
        where = "params" if "\n" in str(source) else str(source)
        return params_from_dict(load_yaml(source), where)

    # -- derived quantities --------------------------------------------------------------------
    @property
    def cable_stiffness(self) -> tuple[float, ...]:
        """Tendon + drive stiffness k (N/m) of every cable, in cable order."""
        k = self.tendon_stiffness
        return k if isinstance(k, tuple) else (k,) * self.n_cables

    @property
    def cable_pretension(self) -> tuple[float, ...]:
        """Pretension T0 (N) of every cable, in cable order."""
        t0 = self.tendon_pretension
        return t0 if isinstance(t0, tuple) else (t0,) * self.n_cables

    @property
    def n_sections(self) -> int:
        """Number of sections."""
        return len(self.sections)

    @property
    def n_cables(self) -> int:
        """Number of cables (= action entries)."""
        return sum(s.n_cables for s in self.sections)

    @property
    def cable_section(self) -> tuple[int, ...]:
        """Index (0-based) of the section each cable ends in, in cable order."""
        return tuple(j for j, s in enumerate(self.sections) for _ in s.cable_angles)

    @property
    def cable_angles(self) -> tuple[float, ...]:
        """Angle β (rad) of every cable, in cable order."""
        return tuple(a for s in self.sections for a in s.cable_angles)

    @property
    def cable_radii(self) -> tuple[float, ...]:
        """Routing radius r (m) of every cable, in cable order."""
        return tuple(s.cable_radius for s in self.sections for _ in s.cable_angles)

    @property
    def section_lengths(self) -> tuple[float, ...]:
        """Length ℓ_j (m) of every section, proximal first."""
        return tuple(s.length for s in self.sections)

    @property
    def cable_run_lengths(self) -> tuple[float, ...]:
        """Length (m) of backbone each cable runs along (base to its section's end), cable order."""
        ends = np.cumsum(self.section_lengths)
        return tuple(float(ends[j]) for j in self.cable_section)

    @property
    def second_moment_of_area(self) -> float:
        """I = π d⁴ / 64 of the circular backbone section (m⁴)."""
        return math.pi * self.backbone_diameter**4 / 64.0

    @property
    def bending_stiffness(self) -> float:
        """EI (N·m²)."""
        return self.youngs_modulus * self.second_moment_of_area

    @property
    def disk_spacing(self) -> float:
        """Arc length h between consecutive disks (m) of a one-section robot.

        Raises:
            ValueError: for a robot of several sections (use ``sections[j].disk_spacing``).
        """
        if self.n_sections != 1:
            raise ValueError(
                f"disk_spacing is per section for a {self.n_sections}-section robot: "
                f"use params.sections[j].disk_spacing"
            )
        return self.sections[0].disk_spacing

    @property
    def backbone_linear_density(self) -> float:
        """Mass per unit length of the backbone rod (kg/m)."""
        return self.backbone_density * math.pi * self.backbone_diameter**2 / 4.0

    @property
    def max_bending_angle(self) -> float:
        """θ (rad) of the distal section pulled by one of its cables at ``max_tension``.

        T·r·ℓ/EI in the pure-moment model; for the paper's robot (cables at 120°) it is also
        the largest bend the tension limit allows (79.4°).
        """
        s = self.sections[-1]
        radius = s.cable_radius
        if self.cable_pitch != 0.0:  # the helix's mean over the section (section_cable_vectors)
            half = 0.5 * self.cable_pitch * s.length
            radius *= math.sin(half) / half
        return self.max_tension * radius * s.length / self.bending_stiffness

    def disk_arc_positions(self) -> np.ndarray:
        """Arc length (m) of every disk from the base, shape (n_disks + 1,): the base disk (0)
        first, then every spacer disk, proximal first (section j's last disk at its end)."""
        z, start = [0.0], 0.0
        for s in self.sections:
            z.extend(start + s.length * k / s.n_disks for k in range(1, 1 + s.n_disks))
            start = z[-1]
        return np.asarray(z)

    def cable_angles_at_disks(self) -> np.ndarray:
        """Angle (rad) of every cable's pinhole on every disk, shape (n_disks + 1, C): β_i +
        p·z_k (p the :attr:`cable_pitch`, z_k from :meth:`disk_arc_positions`); a cable's
        pinholes exist only on the disks of its own and the proximal sections."""
        z = self.disk_arc_positions()
        return np.asarray(self.cable_angles)[None, :] + self.cable_pitch * z[:, None]

    def section_cable_vectors(self) -> np.ndarray:
        """The cables' radius vectors in every section, shape (C, S, 2) m: cable i in section
        j (0 where it does not pass) at r_i·sinc(p·ℓ_j/2)·(cos, sin)(β_i + p·z_j), z_j the
        section's middle and p the :attr:`cable_pitch` (p = 0: r_i·(cos β_i, sin β_i) in every
        section it passes). Every moment and cable length of the constant-curvature model is
        linear in these: a helical cable's moment and shortening averaged over the section."""
        lengths = np.asarray(self.section_lengths)
        middles = np.cumsum(lengths) - 0.5 * lengths
        p = self.cable_pitch
        angles = np.asarray(self.cable_angles)[:, None] + p * middles[None, :]  # (C, S)
        half = 0.5 * p * lengths
        scale = np.where(half == 0.0, 1.0, np.sin(half) / np.where(half == 0.0, 1.0, half))
        radii = np.asarray(self.cable_radii)[:, None] * scale[None, :]
        through = np.asarray(self.cable_section)[:, None] >= np.arange(self.n_sections)[None, :]
        vectors = radii[..., None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
        return np.where(through[..., None], vectors, 0.0)

    @property
    def section_bend_limits(self) -> tuple[float, ...]:
        """Largest bend θ_j (rad) each section reaches with tensions in [0, max_tension].

        Section j bends by κ_j ℓ_j with κ_j = |Σ T_i r_i u_i| / EI over the cables through it
        (its own and every distal section's). The largest norm over the tension box is attained
        at a vertex of the box: for a direction d the maximising vertex pulls exactly the cables
        with r_i u_i·d > 0, and these sets only change where d is perpendicular to some u_i, so
        one direction inside each of those arcs gives every candidate vertex (exact).
        """
        vectors = self.section_cable_vectors()
        owner = np.asarray(self.cable_section)
        limits = []
        for j, section in enumerate(self.sections):
            gens = vectors[owner >= j, j]
            angles = np.arctan2(gens[:, 1], gens[:, 0])
            crit = np.sort(
                np.mod(np.concatenate([angles + 0.5 * np.pi, angles - 0.5 * np.pi]), 2 * np.pi)
            )
            mids = 0.5 * (crit + np.roll(crit, -1))
            mids[-1] += np.pi  # the arc that wraps through 2π
            dirs = np.stack([np.cos(mids), np.sin(mids)], axis=-1)
            pulled = (dirs @ gens.T) > 0.0
            moments = pulled.astype(np.float64) @ gens
            best = float(np.max(np.hypot(moments[:, 0], moments[:, 1]), initial=0.0))
            limits.append(self.max_tension * best * section.length / self.bending_stiffness)
        return tuple(limits)


def _common_radius(sections: tuple[SectionParams, ...]) -> float | None:
    radii = {s.cable_radius for s in sections}
    return radii.pop() if len(radii) == 1 else None


def _tdcr2() -> RobotParams:
    """Rao et al. 2021's two-section reference robot (see :data:`PRESETS`)."""
    angles = (math.radians(90.0), math.radians(-30.0), math.radians(210.0))
    section = SectionParams(length=0.2, n_disks=10, cable_radius=0.010, cable_angles=angles)
    diameter = 0.0014
    return RobotParams(
        sections=(section, section),
        backbone_diameter=diameter,
        youngs_modulus=54e9,
        max_tension=6.0,
        backbone_density=0.0115 / (math.pi * diameter**2 / 4.0),  # 0.0115 kg/m
        disk_mass=0.0002,
        disk_radius=0.012,
        disk_thickness=0.001,
        tendon_stiffness=1.0e4,
        tendon_pretension=0.5,
        displacement_range=(-0.035, 0.035),
    )


#: The FTDCR v4's nominal description (``data/real/ftdcr_v4/robot_nominal.json``): section
#: angle offsets and per-tendon angle deltas (rad); tendon k of section j sits at
#: offset_j + k·2π/3 + delta_jk.
FTDCR_V4_SECTION_OFFSETS = (-3.0589, -2.5615, -2.0506)
FTDCR_V4_TENDON_ANGLE_DELTAS = (
    (0.0092, 0.1303, -0.1395),
    (0.1411, -0.1228, -0.0183),
    (-0.1351, 0.0243, 0.1108),
)
#: Its nominal tendon pretensions (N), in cable order (base section first).
FTDCR_V4_PRETENSION = (
    0.0005778742714404039,
    0.0005778742714404039,
    0.0005778742714404039,
    1.160521809308655,
    1.160521809308655,
    1.160521809308655,
    3.8746889591736853,
    3.8746889591736853,
    3.8746889591736853,
)


def _ftdcr_v4() -> RobotParams:
    """The three-section FTDCR v4 from its nominal description (see :data:`PRESETS`)."""
    sections = tuple(
        SectionParams(
            length=length,
            n_disks=10,
            cable_radius=0.0045,
            cable_angles=tuple(
                offset + k * 2.0 * math.pi / 3.0 + delta for k, delta in enumerate(deltas)
            ),
        )
        for length, offset, deltas in zip(
            (0.06, 0.0625, 0.064), FTDCR_V4_SECTION_OFFSETS, FTDCR_V4_TENDON_ANGLE_DELTAS
        )
    )
    return RobotParams(
        sections=sections,
        backbone_diameter=0.001,
        youngs_modulus=50e9,
        max_tension=9.0,
        backbone_density=37708.0,
        disk_mass=1e-4,
        disk_radius=0.0055,
        disk_thickness=0.001,
        tendon_stiffness=7000.0,
        tendon_pretension=FTDCR_V4_PRETENSION,
        displacement_range=(-0.010, 0.0125),
    )


#: Named robots for ``RobotParams.preset(name)`` and ``gymnasium.make(id, robot=name)``.
#:
#: * ``"paper"``: the paper's robot (one section, Table 1, E = 35 GPa) — the default.
#: * ``"tdcr2"``: the two-section reference robot of Rao et al., *How to model tendon-driven
#:   continuum robots and benchmark modelling performance*, Front. Robot. AI 2021: two sections
#:   of 200 mm with 10 disks each, routing radius 10 mm, three cables per section at 90°, −30°,
#:   210°, backbone E = 54 GPa, solid 1.4 mm diameter (EI ≈ 0.0102 N·m²), 0.0115 kg/m, disks of
#:   0.2 g (disk radius 12 mm and thickness 1 mm are our choice). ``max_tension`` = 6 N: the
#:   proximal section carries the moments of all six cables, so it bends up to
#:   2·T·r·ℓ/EI = 135° at 6 N (the distal one 67.5°); 8 N would reach the 180° limit.
#:   Drive: k = 10⁴ N/m (a 0.25 mm steel wire, EA ≈ 10⁴ N, over ≈ 0.7 m from drive to anchor
#:   is ≈ 1.4·10⁴ N/m alone; the drive in series lowers it), T0 = 0.5 N, range ±35 mm: the
#:   distal tendons run through both sections and shorten by up to r·(θ1 + θ2) ≈ 35 mm at the
#:   bend limits, so +35 mm saturates a tendon and −35 mm releases one on the outside of a bend.
#: * ``"ftdcr_v4"``: the three-section, nine-tendon FTDCR v4 whose hardware recordings are in
#:   ``data/real/ftdcr_v4/`` (OpenCR-MuJoCo, MIT; Shentu et al. 2026), from its nominal
#:   description ``robot_nominal.json``: sections of 60 / 62.5 / 64 mm with 10 links (→ disks)
#:   each; backbone rod Ø 1 mm, E = 50 GPa (EI ≈ 2.45·10⁻³ N·m²), density 37 708 kg/m³ (the
#:   JSON's, which carries all the moving mass in its simulator: 5.5 g); three tendons per
#:   section at 4.5 mm, tendon k of section j at offset_j + k·120° + delta_jk
#:   (:data:`FTDCR_V4_SECTION_OFFSETS`, :data:`FTDCR_V4_TENDON_ANGLE_DELTAS`); disk radius
#:   5.5 mm (the JSON's link radius); disk mass 0.1 g and thickness 1 mm are our choice (the
#:   JSON has no disks). Drive: the nominal position actuators, k = 7 000 N/m (``tendon_kp``,
#:   the same for all: inverse-length scaling with factor 1) and the nominal pretensions
#:   (:data:`FTDCR_V4_PRETENSION`: ≈ 0 / 1.16 / 3.87 N per section). ``max_tension`` = 9 N:
#:   the base section carries the moments of all nine tendons and bends through up to
#:   9.29 N · 19.4°/N = 180° at the worst vertex of the tension box, so 9 N (174°) is the
#:   largest round value the bend limit allows (the simulator's 100 N force range would allow
#:   far more than 180°). With the nominal drive the recorded commands ask for up to 12.6 N
#:   (train) / 22 N (val); at 9 N 5 % of the training rows and 14 % of the held-out rows
#:   saturate a tendon, which moves the modelled tip by < 1 mm on average (mean tip error
#:   without offset removal 11.0 mm either way on train.csv). ``displacement_range`` =
#:   (−10 mm, +12.5 mm): the recorded commands span −10.0 … +9.6 mm (train.csv) and
#:   −9.9 … +12.4 mm (val.csv); −10 mm is the drives' "released".
PRESETS: dict[str, RobotParams] = {
    "paper": RobotParams(),
    "tdcr2": _tdcr2(),
    "ftdcr_v4": _ftdcr_v4(),
}


# -- plain mappings (the YAML format of cdcr_gym.model.params_yaml) --------------------------------
_DERIVED = ("length", "n_disks", "cable_radius")
_SECTION_KEYS = tuple(f.name for f in fields(SectionParams))
#: keys of a top-level file that holds the robot under ``robot:`` (each a mapping)
_FILE_KEYS = ("robot", "backend", "calibration")


def _plain_field(value: Any) -> Any:
    if isinstance(value, tuple):
        return [float(v) for v in value]
    return float(value)


def params_to_dict(params: RobotParams) -> dict[str, Any]:
    """Plain-Python mapping of ``params`` (SI units; sections as a list of mappings; per-cable
    drive values and the displacement range as lists)."""
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    out: dict[str, Any] = {}
    for f in fields(RobotParams):
        if f.name in ("sections",) + _DERIVED:
            continue
        if f.name == "cable_pitch" and params.cable_pitch == 0.0:
            continue  # parallel routing: the key is written only for a helix
        out[f.name] = _plain_field(getattr(params, f.name))
    out["sections"] = [
        {
            "length": float(s.length),
            "n_disks": int(s.n_disks),
            "cable_radius": float(s.cable_radius),
            "cable_angles": [float(a) for a in s.cable_angles],
        }
        for s in params.sections
    ]
    return out


def params_from_dict(data: Any, where: str = "params") -> RobotParams:
    """RobotParams from a mapping (the YAML format of :mod:`cdcr_gym.model.params_yaml`).

    Raises:
        ValueError: naming the key (as a dotted path under ``where``) for unknown keys, a wrong
            type (a list or string where a mapping is expected), or a value RobotParams rejects.
    """
    if not isinstance(data, dict):
        raise ValueError(
            f"{where} must be a mapping of RobotParams fields, got {type(data).__name__} {data!r}"
        )
    if "robot" in data and set(data) <= set(_FILE_KEYS):
        for key in _FILE_KEYS:
            if key in data and data[key] is not None and not isinstance(data[key], dict):
                raise ValueError(
                    f"{where}.{key} must be a mapping, got {type(data[key]).__name__} {data[key]!r}"
                )
        return params_from_dict(data["robot"], f"{where}.robot")
    allowed = {f.name for f in fields(RobotParams)} | {"preset"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; accepted: {sorted(allowed)}")
    kwargs = {k: number(v) for k, v in data.items() if k not in ("preset", "sections")}
    for key in _DRIVE_KEYS:
        if isinstance(kwargs.get(key), list):
            kwargs[key] = tuple(kwargs[key])
    if "sections" in data:
        raw = data["sections"]
        if not isinstance(raw, list) or not raw:
            raise ValueError(f"{where}.sections must be a non-empty list of mappings, got {raw!r}")
        sections = []
        for j, s in enumerate(raw):
            if not isinstance(s, dict):
                raise ValueError(
                    f"{where}.sections[{j}] must be a mapping, got {type(s).__name__} {s!r}"
                )
            bad = sorted(set(s) - set(_SECTION_KEYS))
            if bad:
                raise ValueError(
                    f"{where}.sections[{j}]: unknown key(s) {bad}; accepted: {list(_SECTION_KEYS)}"
                )
            section = {k: number(v) for k, v in s.items()}
            if "cable_angles" in section and isinstance(section["cable_angles"], list):
                section["cable_angles"] = tuple(section["cable_angles"])
            sections.append(SectionParams(**section))
        kwargs["sections"] = tuple(sections)
    if "preset" in data:
        name = data["preset"]
        if not isinstance(name, str) or name not in PRESETS:
            raise ValueError(f"{where}.preset must be one of {sorted(PRESETS)}, got {name!r}")
        return RobotParams.preset(name, **kwargs)
    return RobotParams(**kwargs)
