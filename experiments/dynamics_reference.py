"""Bending natural frequencies of the clamped robots from a converged finite-element beam.

``python -m experiments.dynamics_reference --out experiments/dynamics/reference.json``

An independent reference for the transient of the physics backends (``experiments.dynamics_check``
compares them): the first two bending frequencies of the paper robot, ``tdcr2`` and ``ftdcr_v4``,
clamped at the base disk, small vibrations about the straight pose, from a finite-element
Rayleigh beam (Euler–Bernoulli stiffness, translational and rotary inertia of the rod) with the
spacer disks as lumped masses and rotary inertias, refined until the frequencies no longer change.

The robot (read from ``RobotParams`` with the mass model of ``cdcr_gym.model.discrete``)
    * rod: bending stiffness EI, linear density μ = ``backbone_linear_density``, rotary inertia
      per length μ·d²/16 (solid circular section: I/A = d²/16);
    * disks at s = k·h_j of every section (the base disk clamped), each a point mass
      ``disk_mass`` with the rotary inertia about a diameter m_d·(3R² + t²)/12 (the solid disk of
      ``DiscreteBackbone._link_properties``); the tip disk is the robot's last disk;
    * the bending planes decouple at the straight pose (EI and the masses are axisymmetric), so
      one planar problem gives each frequency, which the robot has twice (x and y plane).

Loads kept in the linearisation (geometric stiffness, consistent element matrices)
    * **gravity** (upright robot, −9.81 m/s² along the backbone): the axial force
      N(s) = −g·(mass distal to s) compresses the rod; a dead load, element geometric stiffness
      N/(30ℓ_e)·[36, 3ℓ_e, …] with N at the element's midpoint (plus the disk weights at the
      nodes). It lowers the frequencies; ``gravity`` on/off are both tabulated.
    * **taut cables** (every cable at the same tension T, frictionless, anchored at its
      section's last disk): each straight cable segment between two disks pulls both disks
      along its chord. At the straight pose the cable moments cancel (cables at 120°) and, to
      first order, the lateral displacement of a pinhole equals the backbone's at its disk, so
      a span crossed by cables of total tension P_k = Σ T carries (a) the backbone compression
      P_k (beam geometric stiffness, N = −P_k) and (b) the cables' chord stiffness
      P_k/h_k·[[1, −1], [−1, 1]] between the lateral displacements of its two disks. For a rod
      that stays straight between the disks (b) cancels (a) exactly (the follower load of a
      continuously routed tendon adds no lateral stiffness); what is left is the span-column
      softening of a rod that curves between the disks (relative energy ≈ P_k·h²/(12·EI) per
      span), the same physics as the span buckling of ``cdcr_gym.model.discrete``. A
      pure-moment tendon model (the analytic backend's) has no such term: there, tension adds
      no lateral stiffness at all. ``ftdcr_v4``'s tendons sit a few degrees off 120°, so equal
      tensions leave a small net moment; the reference ignores it (the straight pose), the
      backends are linearised about their own (slightly bent) equilibrium.
      "Mid tension" is ``max_tension``/2 on every cable.

Convergence: the disk spans are cut into e = 1, 2, 4, 8 elements each; the JSON keeps
every level's frequencies and the relative change of the last refinement (Hermite cubics
converge at O(ℓ_e⁴); finer meshes only add round-off: the stiffness grows as ℓ_e⁻³).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.optimize

from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams

__all__ = [
    "ROBOTS",
    "beam_frequencies",
    "uniform_beam_frequencies",
    "robot_reference",
    "build_reference",
]

#: Robots of the reference (``RobotParams.preset`` names).
ROBOTS = ("paper", "tdcr2", "ftdcr_v4")

#: Elements per disk span at the refinement levels.
REFINEMENTS = (1, 2, 4, 8)


def _element(length: float, ei: float, mu: float, rho_i: float, axial: float):
    """Stiffness, mass and geometric-stiffness matrices (4, 4) of one Hermite beam element
    (DOFs w_a, θ_a, w_b, θ_b; m, rad) of ``length`` (m), EI (N·m²), linear density ``mu``
    (kg/m), rotary inertia per length ``rho_i`` (kg·m) and axial force ``axial`` (N, tension
    positive)."""
    L = length
    k = (
        ei
        / L**3
        * np.array(
            [
                [12, 6 * L, -12, 6 * L],
                [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                [-12, -6 * L, 12, -6 * L],
                [6 * L, 2 * L * L, -6 * L, 4 * L * L],
            ]
        )
    )
    m = (
        mu
        * L
        / 420.0
        * np.array(
            [
                [156, 22 * L, 54, -13 * L],
                [22 * L, 4 * L * L, 13 * L, -3 * L * L],
                [54, 13 * L, 156, -22 * L],
                [-13 * L, -3 * L * L, -22 * L, 4 * L * L],
            ]
        )
    )
    g = np.array(
        [
            [36, 3 * L, -36, 3 * L],
            [3 * L, 4 * L * L, -3 * L, -L * L],
            [-36, -3 * L, 36, -3 * L],
            [3 * L, -L * L, -3 * L, 4 * L * L],
        ]
    ) / (30.0 * L)
    return k + axial * g, m + rho_i * g


def beam_frequencies(
    spans: list[tuple[float, int]],
    ei: float,
    mu: float,
    rho_i: float,
    node_masses: list[tuple[float, float]],
    span_loads: list[float],
    elements_per_span: int,
    gravity: float = 0.0,
    n_modes: int = 2,
) -> np.ndarray:
    """The lowest ``n_modes`` bending frequencies (Hz) of a clamped-free beam.

    Args:
        spans: (length m, count) runs of equal disk spans, base first.
        ei, mu, rho_i: EI (N·m²), linear density (kg/m), rotary inertia per length (kg·m).
        node_masses: per disk (one per span, at its distal end): (mass kg, rotary inertia kg·m²).
        span_loads: per span, the total tension P_k (N) of the cables crossing it (module
            docstring: backbone compression plus the cables' chord stiffness).
        elements_per_span: Hermite elements per span.
        gravity: g (m/s²) along −backbone (upright robot); 0 for none.
    """
    e = elements_per_span
    lengths = [h for h, count in spans for _ in range(count)]
    n_span = len(lengths)
    n_nodes = n_span * e + 1
    ndof = 2 * n_nodes
    elem_len = np.repeat(np.asarray(lengths) / e, e)
    # masses distal to every element's midpoint (gravity's axial compression)
    disk_m = np.array([nm[0] for nm in node_masses])
    elem_mid_s = np.cumsum(elem_len) - 0.5 * elem_len
    disk_s = np.cumsum(lengths)
    total = float(np.sum(elem_len))
    stiff = np.zeros((ndof, ndof))
    mass = np.zeros((ndof, ndof))
    for i, le in enumerate(elem_len):
        span = i // e
        distal = mu * (total - elem_mid_s[i]) + disk_m[disk_s > elem_mid_s[i]].sum()
        axial = -gravity * distal - span_loads[span]
        k, m = _element(float(le), ei, mu, rho_i, axial)
        idx = slice(2 * i, 2 * i + 4)
        stiff[idx, idx] += k
        mass[idx, idx] += m
    for span, (md, jd) in enumerate(node_masses):
        node = (span + 1) * e
        mass[2 * node, 2 * node] += md
        mass[2 * node + 1, 2 * node + 1] += jd
        # the cables' chord stiffness across the span (lateral DOFs of its two disks)
        p, h = span_loads[span], lengths[span]
        a, b = 2 * (node - e), 2 * node
        stiff[a, a] += p / h
        stiff[b, b] += p / h
        stiff[a, b] -= p / h
        stiff[b, a] -= p / h
    free = slice(2, ndof)  # clamp the base node (w = θ = 0)
    eig = scipy.linalg.eigh(
        stiff[free, free], mass[free, free], eigvals_only=True, subset_by_index=[0, n_modes - 1]
    )
    return np.sqrt(eig) / (2.0 * math.pi)


def uniform_beam_frequencies(
    length: float, ei: float, mu: float, tip_mass: float = 0.0, n_modes: int = 2
) -> np.ndarray:
    """Analytic clamped-free Euler–Bernoulli frequencies (Hz), optionally with a tip point mass
    (no rotary inertia): the roots λ of 1 + cos λ·cosh λ + (M/(μℓ))·λ·(cos λ·sinh λ −
    sin λ·cosh λ) = 0, ω = λ²·√(EI/(μℓ⁴)) (λ₁ = 1.8751 without the mass)."""
    ratio = tip_mass / (mu * length)

    def f(lam: float) -> float:
        c, s, ch, sh = math.cos(lam), math.sin(lam), math.cosh(lam), math.sinh(lam)
        return 1.0 + c * ch + ratio * lam * (c * sh - s * ch)

    roots, grid = [], np.linspace(0.05, 20.0, 4000)
    vals = [f(x) for x in grid]
    for a, b, fa, fb in zip(grid[:-1], grid[1:], vals[:-1], vals[1:]):
        if fa * fb < 0.0:
            roots.append(scipy.optimize.brentq(f, a, b, xtol=1e-14))
            if len(roots) == n_modes:
                break
    lam = np.asarray(roots)
    return lam**2 * math.sqrt(ei / (mu * length**4)) / (2.0 * math.pi)


def _robot_model(params: RobotParams, tension: float) -> dict:
    """The beam data of a robot (see :func:`beam_frequencies`) with every cable at ``tension``."""
    spans = [(s.disk_spacing, s.n_disks) for s in params.sections]
    md, rd, t = params.disk_mass, params.disk_radius, params.disk_thickness
    owner = np.asarray(params.cable_section)
    loads = [
        tension * float(np.count_nonzero(owner >= j))
        for j, s in enumerate(params.sections)
        for _ in range(s.n_disks)
    ]
    return {
        "spans": spans,
        "ei": params.bending_stiffness,
        "mu": params.backbone_linear_density,
        "rho_i": params.backbone_linear_density * params.backbone_diameter**2 / 16.0,
        "node_masses": [(md, md * (3 * rd * rd + t * t) / 12.0)] * params.n_disks,
        "span_loads": loads,
    }


def robot_reference(name: str) -> dict:
    """Reference frequencies of one preset: cables slack and at ``max_tension``/2, gravity
    off and on, every refinement level (Hz)."""
    params = RobotParams.preset(name)
    cases = {}
    for cables, tension in (("slack", 0.0), ("taut", 0.5 * params.max_tension)):
        model = _robot_model(params, tension)
        for grav in (False, True):
            levels = [
                beam_frequencies(
                    **model, elements_per_span=e, gravity=STANDARD_GRAVITY if grav else 0.0
                ).tolist()
                for e in REFINEMENTS
            ]
            last, prev = np.asarray(levels[-1]), np.asarray(levels[-2])
            cases[f"{cables}_gravity_{'on' if grav else 'off'}"] = {
                "tension_per_cable_N": tension,
                "gravity": grav,
                "frequencies_hz": levels[-1],
                "refinement": {str(e): f for e, f in zip(REFINEMENTS, levels)},
                "last_refinement_rel_change": float(np.max(np.abs(last - prev) / last)),
            }
    total_disks = params.n_disks * params.disk_mass
    return {
        "length_m": params.length,
        "bending_stiffness_Nm2": params.bending_stiffness,
        "rod_linear_density_kg_per_m": params.backbone_linear_density,
        "rod_mass_kg": params.backbone_linear_density * params.length,
        "disk_mass_kg": params.disk_mass,
        "disks_total_mass_kg": total_disks,
        "disk_rotary_inertia_kgm2": _robot_model(params, 0.0)["node_masses"][0][1],
        "cases": cases,
    }


def build_reference() -> dict:
    """The whole reference (the JSON's content)."""
    checks = {}
    # analytic checks: a uniform clamped-free beam (the paper rod) without and with a tip mass
    p = RobotParams.preset("paper")
    ei, mu, length = p.bending_stiffness, p.backbone_linear_density, p.length
    for tip in (0.0, 0.05):
        fe = beam_frequencies(
            [(length / 9, 9)],
            ei,
            mu,
            0.0,
            [(0.0, 0.0)] * 8 + [(tip, 0.0)],
            [0.0] * 9,
            elements_per_span=REFINEMENTS[-1],
        )
        checks[f"uniform_beam_tip_mass_{tip:g}kg"] = {
            "length_m": length,
            "bending_stiffness_Nm2": ei,
            "linear_density_kg_per_m": mu,
            "tip_mass_kg": tip,
            "fe_hz": fe.tolist(),
            "analytic_hz": uniform_beam_frequencies(length, ei, mu, tip).tolist(),
        }
    return {
        "description": (
            "First two bending natural frequencies (Hz) of the clamped robots, small vibrations "
            "about the straight pose: finite-element Rayleigh beam with lumped disk masses and "
            "rotary inertias (experiments/dynamics_reference.py docstring)"
        ),
        "command": "python -m experiments.dynamics_reference --out experiments/dynamics/reference.json",
        "refinements_elements_per_span": list(REFINEMENTS),
        "robots": {name: robot_reference(name) for name in ROBOTS},
        "analytic_checks": checks,
    }


def main(argv: list[str] | None = None) -> None:  # pragma: no cover
    parser = argparse.ArgumentParser(
        prog="python -m experiments.dynamics_reference", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--out", type=Path, default=Path("experiments/dynamics/reference.json"))
    args = parser.parse_args(argv)
    ref = build_reference()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(ref, indent=2) + "\n")
    for name, robot in ref["robots"].items():
        for case, data in robot["cases"].items():
            f1, f2 = data["frequencies_hz"]
            print(
                f"{name:9s} {case:20s} f1 = {f1:9.4f} Hz  f2 = {f2:9.4f} Hz  "
                f"(last refinement {data['last_refinement_rel_change']:.1e})"
            )
    for name, chk in ref["analytic_checks"].items():
        print(name, "FE", np.round(chk["fe_hz"], 5), "analytic", np.round(chk["analytic_hz"], 5))
    print("wrote", args.out)


if __name__ == "__main__":  # pragma: no cover
    main()
