"""Robot parameters: one frozen dataclass, SI units, the paper's Table 1 as defaults."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

__all__ = ["RobotParams", "CABLE_ANGLES"]

#: Angular positions β_i of cables 1, 2, 3 around the backbone, measured from +X0 about +Z0 (rad).
CABLE_ANGLES: tuple[float, float, float] = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)


@dataclass(frozen=True)
class RobotParams:
    """A 2-DOF cable-driven continuum robot, in SI units (m, kg, Pa, N).

    Defaults are the paper's Table 1 (ℓ = 641 mm, d = 5 mm, r = 29 mm, 9 spacer disks), with
    one correction: the paper prints E = 35 MPa, which is a unit slip. With d = 5 mm the second
    moment of area is I = πd⁴/64 ≈ 3.07e-11 m⁴, so EI(35 MPa) ≈ 1.07e-3 N·m² and a pure moment
    of 80 N × 0.029 m would bend the rod through θ = T·r·ℓ/EI ≈ 1 390 rad (≈ 80 000°). With
    E = 35 GPa (a glass-fibre composite) the same load gives θ ≈ 1.39 rad ≈ 79°, consistent with
    the 0–80 N range the paper applies. We therefore use 35 GPa.

    Masses are not in the paper; the defaults are plausible documented choices: a glass-fibre
    composite rod of density 1 900 kg/m³ (≈ 0.037 kg/m for d = 5 mm) and 10 g spacer disks.

    Attributes:
        length: backbone length ℓ (m), inextensible.
        backbone_diameter: backbone rod diameter d (m).
        cable_radius: distance r of the three cables from the backbone axis (m).
        youngs_modulus: Young's modulus E of the backbone (Pa).
        n_disks: spacer disks along the backbone, evenly spaced, the last one at the tip
            (a fixed base disk at s = 0 comes in addition).
        max_tension: cable tension limit (N); tensions live in [0, max_tension].
        backbone_density: volumetric density of the backbone rod (kg/m³).
        disk_mass: mass of one spacer disk (kg).
        disk_radius: outer radius of a spacer disk (m); used for inertia and drawing.
        disk_thickness: thickness of a spacer disk along the backbone (m).

    Raises:
        ValueError: naming the field and the offending value, for any non-finite or
            non-positive physical quantity, ``n_disks < 1``, or ``disk_radius <= cable_radius``.
    """

    length: float = 0.641
    backbone_diameter: float = 0.005
    cable_radius: float = 0.029
    youngs_modulus: float = 35e9
    n_disks: int = 9
    max_tension: float = 80.0
    backbone_density: float = 1900.0
    disk_mass: float = 0.010
    disk_radius: float = 0.035
    disk_thickness: float = 0.003

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "n_disks":
                if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                    raise ValueError(f"RobotParams.n_disks must be an integer >= 1, got {value!r}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"RobotParams.{f.name} must be a real number, got {value!r}")
            if not math.isfinite(value) or value <= 0.0:
                raise ValueError(
                    f"RobotParams.{f.name} must be finite and > 0 (SI units), got {value!r}"
                )
        if self.disk_radius <= self.cable_radius:
            raise ValueError(
                f"RobotParams.disk_radius ({self.disk_radius!r} m) must exceed "
                f"cable_radius ({self.cable_radius!r} m): the pinholes sit on the disks"
            )

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
        """Arc length h between consecutive disks, base disk included (m)."""
        return self.length / self.n_disks

    @property
    def backbone_linear_density(self) -> float:
        """Mass per unit length of the backbone rod (kg/m)."""
        return self.backbone_density * math.pi * self.backbone_diameter**2 / 4.0

    @property
    def max_bending_angle(self) -> float:
        """θ (rad) reached by one cable at ``max_tension`` in the pure-moment model: T·r·ℓ/EI."""
        return self.max_tension * self.cable_radius * self.length / self.bending_stiffness
