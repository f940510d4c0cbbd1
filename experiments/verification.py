"""Verification studies of the pybullet backend: the numbers in ``docs/bullet_backend.md``.

It lives in ``training/`` (the tools that run the package, next to ``training.studies.bench``), not in
the backend: it is a study of the backend against closed-form mechanics, needs nothing a user
of the backend needs, and is not part of the paper's reproduction (``training.studies.reproduce``).

``python -m experiments.verification`` prints every table of that document (a few
seconds); ``python -m experiments.verification --bench`` also measures the speed
(``apply_tensions`` calls per second of the backend and env steps per second of
``cdcr_gym/BulletReach-v0``, both at default settings, as wall-clock and as CPU-time rates).
``tests/test_bullet.py`` asserts the same quantities through these functions.

"Settled" states are static equilibria: :meth:`BulletBackend.static_equilibrium`, which the
simulated dynamics settle to exactly (tests check it). Chains longer than one pybullet
multibody holds (n_disks × links_per_span > 60 joints) are evaluated with the same model's
statics, :class:`~cdcr_gym.model.discrete.DiscreteBackbone`.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from cdcr_gym import kinematics
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.bullet import MAX_JOINTS, BulletBackend
from cdcr_gym.model import statics
from cdcr_gym.model.discrete import DiscreteBackbone, span_buckling_loads
from cdcr_gym.model.params import STANDARD_GRAVITY as GRAVITY
from cdcr_gym.params import PRESETS, RobotParams, SectionParams
from training.run.argtypes import positive_int

__all__ = [
    "HORIZONTAL",
    "elastica_tip",
    "bending_angle_of_tip",
    "discrete_routing_theta",
    "settled_tip",
    "beam_theory_sag",
    "settling_time",
    "benchmark",
    "linearised_critical_load",
]

#: base_orientation that turns the backbone from +Z to +X_world (a horizontal cantilever).
HORIZONTAL = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))


def elastica_tip(tensions: np.ndarray, params: RobotParams) -> np.ndarray:
    """Tip (3,) m of the continuous elastica (pure moment, constant curvature) under tensions."""
    theta, phi = statics.arc_from_tensions(np.asarray(tensions, dtype=np.float64), params)
    return kinematics.tip_from_arc(theta, phi, params.length)


def bending_angle_of_tip(tip: np.ndarray) -> float:
    """Bending angle θ (rad) of the constant-curvature arc through ``tip``: 2·atan2(ρ, z)."""
    return float(2.0 * math.atan2(math.hypot(tip[0], tip[1]), tip[2]))


def discrete_routing_theta(
    tensions: np.ndarray, params: RobotParams, links_per_span: int | None = None
) -> float:
    """Bending angle θ (rad) with the discrete-routing correction of the moment arm.

    A cable straight between disks h apart has the moment arm r + (h²κ/2)·u(1−u) at fraction
    u of a span, r + h²κ/12 on average, and the excess points along the bend for every cable,
    so Σ_i T_i·(h²κ/12) adds to the bending moment: θ = θ₀ + (ΣT)·h²·θ/(12·EI), i.e.
    θ = θ₀ / (1 − ΣT·h²/(12·EI)), θ₀ the elastica's angle. With ``links_per_span`` = m the
    estimate is for the rigid-link model instead, whose span-mean excess is (1 + 2/m²) times
    larger (see ``cdcr_gym.model.discrete``).
    """
    tensions = np.asarray(tensions, dtype=np.float64)
    theta0, _ = statics.arc_from_tensions(tensions, params)
    factor = 1.0 if links_per_span is None else 1.0 + 2.0 / links_per_span**2
    excess = factor * tensions.sum() * params.disk_spacing**2 / (12.0 * params.bending_stiffness)
    return float(theta0) / (1.0 - excess)


def settled_tip(
    tensions: np.ndarray,
    params: RobotParams = RobotParams(),  # noqa: B008 (frozen)
    *,
    links_per_span: int = 1,
    gravity: bool = False,
    base_orientation=(0.0, 0.0, 0.0, 1.0),
    frame: str = "base",
) -> np.ndarray:
    """Tip (3,) m of the settled (static-equilibrium) chain, in R0 or the world frame.

    Uses :class:`BulletBackend` when the chain fits one pybullet multibody, else (gravity off,
    upright only) the same model's statics, :class:`DiscreteBackbone`.
    """
    tensions = np.asarray(tensions, dtype=np.float64)
    if params.n_disks * links_per_span <= MAX_JOINTS:
        backend = BulletBackend(
            params,
            gravity=gravity,
            links_per_span=links_per_span,
            base_orientation=base_orientation,
            routing="disk",
        )
        try:
            backend.reset(tensions)
            return backend.tip_world if frame == "world" else backend.tip
        finally:
            backend.close()
    if gravity or tuple(base_orientation) != (0.0, 0.0, 0.0, 1.0):
        raise ValueError(
            "chains beyond pybullet's limit are evaluated upright without gravity only"
        )
    chain = DiscreteBackbone(params, links_per_span, gravity=False)
    q, converged = chain.static_equilibrium(tensions)
    if not converged:
        raise RuntimeError(f"no static equilibrium under {tensions} N")
    return chain.pose(q).stations[-1]


def beam_theory_sag(params: RobotParams, tip_payload: float = 0.0) -> float:
    """Euler–Bernoulli small-deflection tip sag (m) of the horizontal cantilever.

    Distributed rod weight w = μg: wℓ⁴/(8EI); disk k (weight m_d·g at a_k = k·h) and the
    payload at ℓ: P·a²(3ℓ − a)/(6EI) each.
    """
    ell, ei = params.length, params.bending_stiffness
    w = params.backbone_linear_density * GRAVITY
    a = np.arange(1, params.n_disks + 1) * params.disk_spacing
    disks = np.sum(params.disk_mass * GRAVITY * a**2 * (3.0 * ell - a) / (6.0 * ei))
    payload = tip_payload * GRAVITY * ell**3 / (3.0 * ei)
    return float(w * ell**4 / (8.0 * ei) + disks + payload)


def settling_time(
    backend: BulletBackend,
    start: np.ndarray,
    target: np.ndarray,
    tol: float = 1e-4,
    duration: float = 3.0,
) -> tuple[float, float]:
    """Time (s) until the tip stays within ``tol`` m of its final rest after a tension step.

    Resets to rest under ``start``, holds ``target`` for ``duration`` s. Returns
    ``(settling time, overshoot)``, the overshoot (m) measured along the start → end direction.
    """
    backend.reset(np.asarray(target, dtype=np.float64))
    final = backend.tip
    backend.reset(np.asarray(start, dtype=np.float64))
    first = backend.tip
    tips = []
    for _ in range(int(round(duration / backend.control_timestep))):
        backend.apply_tensions(np.asarray(target, dtype=np.float64))
        tips.append(backend.tip)
    tips = np.array(tips)
    err = np.linalg.norm(tips - final, axis=1)
    outside = np.nonzero(err > tol)[0]
    t_settle = 0.0 if outside.size == 0 else (outside[-1] + 1) * backend.control_timestep
    direction = (final - first) / max(np.linalg.norm(final - first), 1e-12)
    overshoot = float(max(0.0, np.max((tips - final) @ direction)))
    return float(t_settle), overshoot


def benchmark(n_steps: int = 5000, seed: int = 0, robot: str = "paper") -> dict[str, float]:
    """Speed at default settings: backend ``apply_tensions``/s and BulletReach-v0 env steps/s.

    Random uniform tensions (backend) and random actions (env, episodes reset as they
    truncate). Rates per wall-clock second and per CPU second of this process (the latter is
    what one core delivers when other processes share the machine).
    """
    rng = np.random.default_rng(seed)
    backend = BulletBackend(RobotParams.preset(robot))
    c = backend.params.n_cables
    tensions = rng.uniform(0.0, backend.params.max_tension, (n_steps, c))
    backend.reset(np.zeros(c))
    t0, c0 = time.perf_counter(), time.process_time()
    for t in tensions:
        backend.apply_tensions(t)
        backend.tip  # noqa: B018 (what an env reads every step)
        backend.cable_lengths  # noqa: B018
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    backend.close()
    out = {"backend_steps_per_s_wall": n_steps / wall, "backend_steps_per_s_cpu": n_steps / cpu}

    env = gym.make("cdcr_gym/BulletReach-v0", robot=robot)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(n_steps)]
    t0, c0 = time.perf_counter(), time.process_time()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    env.close()
    out.update({"env_steps_per_s_wall": n_steps / wall, "env_steps_per_s_cpu": n_steps / cpu})
    return out


# ------------------------------------------------------------------------------------------
# the report
# ------------------------------------------------------------------------------------------

_TENSION_CASES = {
    "T1 = 10 N": (10.0, 0.0, 0.0),
    "T1 = 40 N": (40.0, 0.0, 0.0),
    "T1 = 80 N": (80.0, 0.0, 0.0),
    "T1 = T2 = 40 N": (40.0, 40.0, 0.0),
}


def _report() -> None:  # pragma: no cover - prints the tables of docs/bullet_backend.md
    p = RobotParams()
    ell = p.length
    print("## Dense-disk limit (gravity off, links_per_span = 1): |tip − elastica| / ℓ (%)\n")
    print("| n_disks | " + " | ".join(_TENSION_CASES) + " |")
    print("|---|" + "---|" * len(_TENSION_CASES))
    for n in (9, 18, 36, 60, 72):
        pn = replace(p, n_disks=n)
        row = [
            100 * np.linalg.norm(settled_tip(t, pn) - elastica_tip(t, pn)) / ell
            for t in _TENSION_CASES.values()
        ]
        print(f"| {n} | " + " | ".join(f"{x:.3f}" for x in row) + " |")

    print(
        "\n## 9 disks, gravity off: bending beyond the elastica vs the discrete-routing estimate\n"
    )
    print(
        "| m | T1 (N) | θ₀ (°) | θ_sim − θ₀ (°) | estimate, physical (°) | estimate, model (1+2/m²) (°) "
        "| |tip − elastica| (mm) | estimate, physical (mm) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for m in (1, 2, 4, 8):
        for t1 in (10.0, 20.0, 40.0, 60.0, 80.0):
            t = np.array([t1, 0.0, 0.0])
            tip = settled_tip(t, p, links_per_span=m)
            th0 = float(statics.arc_from_tensions(t, p)[0])
            th_phys = discrete_routing_theta(t, p)
            th_model = discrete_routing_theta(t, p, m)
            d_sim = np.linalg.norm(tip - elastica_tip(t, p))
            d_est = np.linalg.norm(kinematics.tip_from_arc(th_phys, 0.0, ell) - elastica_tip(t, p))
            print(
                f"| {m} | {t1:.0f} | {math.degrees(th0):.2f} | {math.degrees(bending_angle_of_tip(tip) - th0):.3f} "
                f"| {math.degrees(th_phys - th0):.3f} | {math.degrees(th_model - th0):.3f} "
                f"| {1e3 * d_sim:.2f} | {1e3 * d_est:.2f} |"
            )

    print("\n## links_per_span convergence (9 disks, gravity off): |tip(m) − tip(2m)| (mm)\n")
    print("| T1 (N) | 1→2 | 2→4 | 4→8 | 8→16 | order 1→2→4 | order 2→4→8 | (4→8)/ℓ (%) |")
    print("|---|---|---|---|---|---|---|---|")
    for t1 in (10.0, 40.0, 80.0):
        t = np.array([t1, 0.0, 0.0])
        tips = {m: settled_tip(t, p, links_per_span=m) for m in (1, 2, 4, 8, 16)}
        d = [np.linalg.norm(tips[m] - tips[2 * m]) for m in (1, 2, 4, 8)]
        print(
            f"| {t1:.0f} | "
            + " | ".join(f"{1e3 * x:.3f}" for x in d)
            + f" | {math.log2(d[0] / d[1]):.2f} | {math.log2(d[1] / d[2]):.2f} | {100 * d[2] / ell:.3f} |"
        )

    print("\n## CCKA check (9 disks, T1 = 0…80 N): |forward_kinematics(sensed lengths) − tip|\n")
    print("| gravity | links_per_span | mean (mm) | max (mm) | mean (% ℓ) | max (% ℓ) |")
    print("|---|---|---|---|---|---|")
    for gravity in (False, True):
        for m in (1, 4):
            backend = BulletBackend(p, gravity=gravity, links_per_span=m, routing="disk")
            errs = []
            for t1 in np.linspace(0.0, 80.0, 17):
                backend.reset(np.array([t1, 0.0, 0.0]))
                fk = kinematics.forward_kinematics(backend.cable_lengths, p.cable_radius)
                errs.append(np.linalg.norm(fk - backend.tip))
            backend.close()
            e = np.array(errs)
            print(
                f"| {'on' if gravity else 'off'} | {m} | {1e3 * e.mean():.2f} | {1e3 * e.max():.2f} "
                f"| {100 * e.mean() / ell:.3f} | {100 * e.max() / ell:.3f} |"
            )

    print("\n## Gravity\n")
    beam = beam_theory_sag(p)
    print(f"Euler–Bernoulli cantilever sag (rod + 9 disks): {1e3 * beam:.2f} mm\n")
    print("| links_per_span | simulated sag (mm) | vs beam theory (%) |")
    print("|---|---|---|")
    for m in (1, 2, 4, 6):
        sag = -settled_tip(
            np.zeros(3),
            p,
            links_per_span=m,
            gravity=True,
            base_orientation=HORIZONTAL,
            frame="world",
        )[2]
        print(f"| {m} | {1e3 * sag:.2f} | {100 * (sag / beam - 1):+.2f} |")
    up = settled_tip(np.zeros(3), p, gravity=True)
    print(
        f"\nUpright, zero tension, gravity on: tip = {np.array2string(1e3 * up, precision=6)} mm (no sag)\n"
    )
    print("| tensions (N) | tip, gravity off (mm) | tip, gravity on (mm) | |Δ| (mm) |")
    print("|---|---|---|---|")
    for t in ((40.0, 0.0, 0.0), (80.0, 0.0, 0.0), (0.0, 40.0, 0.0)):
        off = settled_tip(t, p)
        on = settled_tip(t, p, gravity=True)
        print(
            f"| {t} | {np.array2string(1e3 * off, precision=1)} | {np.array2string(1e3 * on, precision=1)} "
            f"| {1e3 * np.linalg.norm(on - off):.2f} |"
        )

    print("\n## Damping and settling (default settings, gravity on): time to stay within 0.1 mm\n")
    print(
        "| damping_ratio | physics_timestep (s) | 0→80 N | 80→0 N | 0→(40, 40, 0) N | max overshoot (mm) |"
    )
    print("|---|---|---|---|---|---|")
    for zeta in (0.5, 0.7, 1.0):
        for h in (0.005, 0.01, 0.02):
            backend = BulletBackend(p, damping_ratio=zeta, physics_timestep=h, routing="disk")
            res = [
                settling_time(backend, np.array(a), np.array(b))
                for a, b in (
                    ((0, 0, 0), (80, 0, 0)),
                    ((80, 0, 0), (0, 0, 0)),
                    ((0, 0, 0), (40, 40, 0)),
                )
            ]
            backend.close()
            print(
                f"| {zeta} | {h} | "
                + " | ".join(f"{r[0]:.2f} s" for r in res)
                + f" | {1e3 * max(r[1] for r in res):.1f} |"
            )
    backend = BulletBackend(p, routing="disk")
    print(
        f"\nFirst bending mode ω₁ = {backend.first_mode_frequency:.2f} rad/s, highest mode "
        f"ω_max = {backend.highest_mode_frequency:.0f} rad/s, damping time β = {backend.damping_time:.4f} s"
    )
    backend.close()


def linearised_critical_load(params: RobotParams, links_per_span: int = 1) -> float:
    """Total cable load (N) at which the straight chain's tangent stiffness turns singular.

    All cables at one tension T: the cable loads at q = 0 are linear in T, τ ≈ T·J·q with
    J = ∂τ/∂q (central finite differences at T = 1 N per cable), and the straight pose is
    stable while K − T·J is positive definite, i.e. up to T_cr = 1/λ_max(K⁻¹·J). Returns
    C·T_cr, to compare with ``chain.span_buckling_loads`` (one-section robots: every cable
    crosses every span).
    """
    chain = DiscreteBackbone(params, links_per_span, gravity=False)
    ones, eps = np.ones(params.n_cables), 1e-6
    cols = [
        (chain.cable_loads(eps * e, ones)[0] - chain.cable_loads(-eps * e, ones)[0]) / (2 * eps)
        for e in np.eye(chain.n_dof)
    ]
    jac = np.array(cols).T
    lam = float(np.max(np.linalg.eigvals(jac / chain.stiffness[:, None]).real))
    return params.n_cables / lam


def _buckling_report() -> None:  # pragma: no cover - prints the span-buckling table
    p = RobotParams()
    print("## Span buckling: the straight chain's critical load, all cables equal (N)\n")
    print("| n_disks | m | linearised chain | (4EI/Δ²)·sin²(π/2m) | Euler π²EI/h² | 3 × 80 N |")
    print("|---|---|---|---|---|---|")
    for n, m in ((3, 1), (4, 1), (5, 1), (9, 1), (3, 2), (4, 2), (3, 4), (3, 12), (4, 9)):
        pn = replace(p, n_disks=n, max_tension=1.0)
        crit = span_buckling_loads(pn, m)[0][0]
        euler = math.pi**2 * p.bending_stiffness / pn.disk_spacing**2
        lin = linearised_critical_load(pn, m)
        print(f"| {n} | {m} | {lin:.1f} | {crit:.1f} | {euler:.1f} | 240 |")


def with_disks(params: RobotParams, n_disks: int) -> RobotParams:
    """``params`` with ``n_disks`` spacer disks in every section."""
    sections = tuple(replace(s, n_disks=n_disks) for s in params.sections)
    return replace(params, sections=sections, length=None, n_disks=None, cable_radius=None)


#: A three-section layout with 4, 3 and 5 cables at other angles (the tests' ``THREE``).
THREE_SECTIONS = replace(
    RobotParams.preset("tdcr2"),
    sections=(
        SectionParams(0.15, 20, 0.011, tuple(math.radians(a) for a in (0, 90, 180, 270))),
        SectionParams(0.15, 20, 0.010, tuple(math.radians(a) for a in (30, 150, 270))),
        SectionParams(0.10, 20, 0.008, tuple(math.radians(a) for a in (10, 100, 200, 300, 350))),
    ),
    max_tension=4.0,
    length=None,
    n_disks=None,
    cable_radius=None,
)


def _sections_report() -> None:  # pragma: no cover - prints the n-section table

    print("## Several sections, gravity off: |settled tip − PCC tip| / ℓ (%)\n")
    print("5 tension sets uniform in [0, max_tension] (seed 0); max and mean over the sets.\n")
    print("| robot | disks per section | links_per_span | max | mean | source |")
    print("|---|---|---|---|---|---|")
    combos = ((10, 1), (10, 2), (10, 3), (20, 1), (30, 1), (60, 1), (100, 1))
    for name, base in (("tdcr2", RobotParams.preset("tdcr2")), ("three sections", THREE_SECTIONS)):
        rng = np.random.default_rng(0)
        tensions = rng.uniform(0.0, base.max_tension, (5, base.n_cables))
        for n, m in combos:
            p = with_disks(base, n)
            pcc = AnalyticBackend(p).equilibrium(tensions).tip
            if p.n_disks * m <= MAX_JOINTS:
                b = BulletBackend(p, gravity=False, links_per_span=m)
                tips, source = b.equilibrium(tensions).tip, "pybullet backend"
                b.close()
            else:
                chain = DiscreteBackbone(p, m, gravity=False)
                tips = np.array(
                    [chain.pose(chain.static_equilibrium(t)[0]).stations[-1] for t in tensions]
                )
                source = "chain statics"
            err = 100 * np.linalg.norm(tips - pcc, axis=1) / p.length
            print(f"| {name} | {n} | {m} | {err.max():.3f} | {err.mean():.3f} | {source} |")


def main(argv: list[str] | None = None) -> None:  # pragma: no cover
    parser = argparse.ArgumentParser(
        prog="python -m experiments.verification", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--bench", action="store_true", help="also measure the speed")
    parser.add_argument("--bench-only", action="store_true", help="only measure the speed")
    parser.add_argument(
        "--steps", type=positive_int, default=5000, help="steps per speed measurement"
    )
    parser.add_argument(
        "--robot", default="paper", choices=sorted(PRESETS), help="robot preset of the speed rows"
    )
    parser.add_argument(
        "--buckling", action="store_true", help="only the span-buckling table (seconds)"
    )
    parser.add_argument(
        "--sections", action="store_true", help="only the n-section dense-disk table (seconds)"
    )
    args = parser.parse_args(argv)
    if args.buckling or args.sections:
        if args.buckling:
            _buckling_report()
        if args.sections:
            _sections_report()
        return
    if not args.bench_only:
        _report()
    if args.bench or args.bench_only:
        res = benchmark(args.steps, robot=args.robot)
        print(f"\n## Speed ({args.robot} robot, default settings, one process)\n")
        print("| what | per wall-clock s | per CPU s |")
        print("|---|---|---|")
        print(
            f"| BulletBackend.apply_tensions (+ tip, cable_lengths) | {res['backend_steps_per_s_wall']:.0f} "
            f"| {res['backend_steps_per_s_cpu']:.0f} |"
        )
        print(
            f"| cdcr_gym/BulletReach-v0 env.step | {res['env_steps_per_s_wall']:.0f} | {res['env_steps_per_s_cpu']:.0f} |"
        )


if __name__ == "__main__":  # pragma: no cover
    main()
