"""PyElastica 1.0 as the cross-check of :func:`experiments.cosserat.rod.solve_static`.

The rod is extended half an element past both ends so that its element centres fall on
s = 0, h/m, …, ℓ: the clamped first element is centred on the base disk (a rod starting at the
clamp would leave half an element rigid), every disk sits at an element centre (forces split to
its two nodes, the couple as an element torque in the material frame). The loads are recomputed
from the deformed shape every step; dynamic relaxation with an ``AnalyticalLinearDamper``.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from cdcr_gym.model.params import RobotParams
from experiments.cosserat.rod import POISSON_RATIO, RodModel

__all__ = ["solve_pyelastica"]


def _node_gravity(model: RodModel, n_elem: int, dx: float) -> np.ndarray:
    """(3, n_elem + 1) N: rod weight on [0, ℓ] and disk weights, lumped consistently on the
    nodes of a rod running from −dx/2 to ℓ + dx/2 (a load at s inside element e goes to its
    nodes in proportion to the distance from the other node)."""
    loads = np.zeros((3, n_elem + 1))
    w = model.weight_per_length
    length = model.stations[-1]
    for e in range(n_elem):
        a, b = e * dx - 0.5 * dx, (e + 1) * dx - 0.5 * dx  # element from node e to e + 1
        lo, hi = max(a, 0.0), min(b, length)
        if hi > lo:
            centroid = 0.5 * (lo + hi)
            weight = w * (hi - lo)
            loads[2, e] -= weight * (b - centroid) / dx
            loads[2, e + 1] -= weight * (centroid - a) / dx
    m = (n_elem - 1) // model.n_disks
    for k in range(1, model.n_disks + 1):  # disk k at the centre of element k·m
        loads[2, k * m] -= 0.5 * model.disk_weight
        loads[2, k * m + 1] -= 0.5 * model.disk_weight
    return loads


def solve_pyelastica(
    params: RobotParams,
    tensions,
    gravity: bool = False,
    *,
    elements_per_span: int = 4,
    final_time: float = 1.5,
    velocity_tol: float = 1e-6,
    damping: float | None = None,
    inertia_scale: float = 100.0,
    dt: float | None = None,
    verbose: bool = False,
) -> dict:
    """The static shape by PyElastica 1.0 dynamic relaxation (module docstring, second solver).

    Args:
        params, tensions, gravity: as :func:`solve_static` (tensions (C,) or (D, C) N).
        elements_per_span: m elements per disk span (all spans of the robot must be equal).
        final_time: simulated-time limit (s).
        velocity_tol: the relaxation stops when the fastest node moves slower (m/s), checked
            every 2 000 steps, and the tip moved < 1e-9 m since the last check.
        damping: uniform velocity damping rate (1/s); default ≈ 2·ω₁ of the bare rod.
        inertia_scale: factor on the elements' rotational inertia (dynamic-relaxation mass
            scaling: lowers the stiff shear–rotation mode so that a larger step is stable;
            statics do not depend on inertia).
        dt: time step (s); default 0.8·dx/√(E/ρ) (the axial wave limit is dx/√(E/ρ)).

    Returns:
        dict with ``tip`` (3,) m, ``disk_centres`` (D + 1, 3) m, ``final_velocity`` (m/s),
        ``time`` (simulated s), ``steps``, ``seconds`` (wall time).
    """
    import elastica as ea

    model = RodModel.of(params, gravity)
    seg_t = model.segment_tensions(tensions)
    spans = np.diff(model.stations)
    if not np.allclose(spans, spans[0], rtol=1e-12):
        raise ValueError("solve_pyelastica needs equal disk spans in every section")
    m = int(elements_per_span)
    d = model.n_disks
    dx = spans[0] / m
    n_elem = d * m + 1
    length = model.stations[-1]
    p = params
    radius = 0.5 * p.backbone_diameter
    g_mod = p.youngs_modulus / (2.0 * (1.0 + POISSON_RATIO))
    wave = math.sqrt(p.youngs_modulus / p.backbone_density)
    dt = 0.8 * dx / wave if dt is None else dt
    if damping is None:
        omega1 = 3.516 * math.sqrt(model.k_bt[0] / (p.backbone_linear_density * length**4))
        damping = 2.0 * omega1

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
        pass

    sim = Sim()
    rod = ea.CosseratRod.straight_rod(
        n_elem,
        np.array([0.0, 0.0, -0.5 * dx]),
        np.array([0.0, 0.0, 1.0]),
        np.array([1.0, 0.0, 0.0]),  # d1 = +X0: the disks' x axis
        length + dx,
        radius,
        p.backbone_density,
        youngs_modulus=p.youngs_modulus,
        shear_modulus=g_mod,
    )
    rod.mass_second_moment_of_inertia *= inertia_scale
    rod.inv_mass_second_moment_of_inertia /= inertia_scale
    sim.append(rod)
    sim.constrain(rod).using(
        ea.FixedConstraint, constrained_position_idx=(0, 1), constrained_director_idx=(0,)
    )
    disk_elems = np.arange(d + 1) * m
    node_gravity = _node_gravity(model, n_elem, dx)
    pin_local = model.pinholes  # (C, 3)

    class Cables(ea.NoForces):
        def apply_forces(self, system, time=0.0):
            x = system.position_collection
            centres = 0.5 * (x[:, disk_elems] + x[:, disk_elems + 1]).T  # (D+1, 3)
            q = system.director_collection[:, :, disk_elems].transpose(2, 0, 1)  # lab→material
            offs = np.einsum("kji,cj->kci", q, pin_local)  # Qᵀ·ρ (D+1, C, 3)
            pins = centres[:, None, :] + offs
            seg = np.diff(pins, axis=0)
            u = seg / np.linalg.norm(seg, axis=-1, keepdims=True)  # (D, C, 3)
            tu = seg_t[..., None] * u
            force = np.zeros_like(pins)
            force[:-1] += tu
            force[1:] -= tu
            couple = np.cross(offs, force).sum(axis=1)  # (D+1, 3) world
            total = force.sum(axis=1)
            ext = system.external_forces
            ext += node_gravity
            ext[:, disk_elems[1:]] += 0.5 * total[1:].T
            ext[:, disk_elems[1:] + 1] += 0.5 * total[1:].T
            system.external_torques[:, disk_elems[1:]] += np.einsum("kij,kj->ik", q[1:], couple[1:])

    sim.add_forcing_to(rod).using(Cables)
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=damping, time_step=dt)
    sim.finalize()
    stepper = ea.PositionVerlet()
    t = 0.0
    steps = 0
    start = time.perf_counter()
    last_tip = None
    speed = math.inf
    while t < final_time:
        for _ in range(2000):
            t = stepper.step(sim, t, dt)
        steps += 2000
        x = rod.position_collection
        tip = 0.5 * (x[:, -2] + x[:, -1])
        speed = float(np.max(np.linalg.norm(rod.velocity_collection, axis=0)))
        if not np.all(np.isfinite(x)):
            raise RuntimeError(f"PyElastica diverged at t = {t} s")
        if verbose and steps % 100000 == 0:
            print(f"  t={t:.3f} s tip={tip * 1e3} mm v={speed:.2e}", file=sys.stderr)
        if speed < velocity_tol and last_tip is not None and np.max(np.abs(tip - last_tip)) < 1e-9:
            break
        last_tip = tip.copy()
    x = rod.position_collection
    centres = 0.5 * (x[:, disk_elems] + x[:, disk_elems + 1]).T
    return {
        "tip": centres[-1].copy(),
        "disk_centres": centres,
        "final_velocity": speed,
        "time": t,
        "steps": steps,
        "seconds": time.perf_counter() - start,
    }
