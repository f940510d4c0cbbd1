"""The backends' bending frequencies and damping against the beam reference.

``python -m experiments.dynamics_check [--out experiments/dynamics/check.json] [--quick]``

Two measurements per backend (``MuJoCoBackend``, ``BulletBackend``, their defaults: one link
per disk span, ``damping_ratio`` 0.7):

* **linearisation** (the model's own frequencies): at the static equilibrium under the cable
  tensions (slack: 0; taut: ``max_tension``/2 on every cable), the mass matrix M (MuJoCo
  ``mj_fullM``, pybullet ``calculateMassMatrix``) and the tangent stiffness K = −∂f/∂q by central
  differences of every generalized force at rest (joint springs, cables, gravity); the
  generalized eigenproblem K·v = ω²·M·v. MuJoCo's ball joints add twist modes: a mode is a
  bending mode if less than half of its coordinates' weight is twist. Bending frequencies
  come in pairs (x and y plane); the table gives each pair's mean (on ``ftdcr_v4``'s slightly
  bent taut pose the pair's members differ a little).
* **free vibration** (what an env sees): the robot rests bent by a small tension on one cable,
  the tension is released (cables slack) and the tip is recorded every physics step; a damped
  sinusoid A·e^(−ζωt)·cos(ω·√(1−ζ²)·t + φ) + c fitted to the tip's deflection gives the first
  mode's ω and ζ. Run at the default physics timestep and at 1 ms (the integrator's share).

Reference: ``experiments/dynamics/reference.json`` (``experiments.dynamics_reference``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.optimize

from cdcr_gym.model.params import RobotParams
from experiments._json_main import json_main

__all__ = [
    "REFERENCE",
    "mujoco_linearised",
    "bullet_linearised",
    "free_vibration",
    "fit_damped_sinusoid",
]

REFERENCE = Path(__file__).parent / "dynamics" / "reference.json"


def _bending_pairs(omega2: np.ndarray, twist: np.ndarray, n_modes: int) -> list[float]:
    """The first ``n_modes`` bending frequencies (Hz) from eigenvalues ω² and twist fractions:
    bending modes sorted, consecutive pairs averaged."""
    keep = np.sort(np.sqrt(np.abs(omega2[twist < 0.5])))
    pairs = keep[: 2 * n_modes].reshape(n_modes, 2)
    return (pairs.mean(axis=1) / (2.0 * math.pi)).tolist()


def _eig(stiff: np.ndarray, mass: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues ω² (real parts) and eigenvectors of K·v = ω²·M·v (K may be unsymmetric:
    the cables' follower forces)."""
    w, v = scipy.linalg.eig(stiff, mass)
    return np.real(w), np.real(v)


def mujoco_linearised(
    name: str, gravity: bool, tension: float, n_modes: int = 2, **kwargs
) -> list[float]:
    """First ``n_modes`` bending frequencies (Hz) of ``MuJoCoBackend`` (``kwargs``) linearised
    at the static equilibrium under ``tension`` (N) on every cable."""
    import mujoco

    from cdcr_gym.backends.mujoco import MuJoCoBackend

    params = RobotParams.preset(name)
    be = MuJoCoBackend(params, gravity=gravity, **kwargs)
    t = np.full((1, params.n_cables), tension)
    be.reset(t)
    model = be.model
    data = mujoco.MjData(model)
    qpos0 = be._datas[0].qpos.copy()
    data.ctrl[: params.n_cables] = tension
    nv = model.nv

    def force(qpos: np.ndarray) -> np.ndarray:
        data.qpos[:] = qpos
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        return data.qfrc_passive + data.qfrc_actuator - data.qfrc_bias

    eps = 1e-6
    stiff = np.empty((nv, nv))
    for i in range(nv):
        dv = np.zeros(nv)
        dv[i] = eps
        plus, minus = qpos0.copy(), qpos0.copy()
        mujoco.mj_integratePos(model, plus, dv, 1.0)
        mujoco.mj_integratePos(model, minus, -dv, 1.0)
        stiff[:, i] = -(force(plus) - force(minus)) / (2.0 * eps)
    data.qpos[:] = qpos0
    mujoco.mj_forward(model, data)
    mass = np.zeros((nv, nv))
    mujoco.mj_fullM(model, data, mass)
    w, v = _eig(stiff, mass)
    twist_dofs = np.zeros(nv, bool)
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            twist_dofs[model.jnt_dofadr[j] + 2] = True
    twist = (v[twist_dofs] ** 2).sum(axis=0) / (v**2).sum(axis=0)
    be.close()
    return _bending_pairs(w, twist, n_modes)


def bullet_linearised(
    name: str, gravity: bool, tension: float, n_modes: int = 2, **kwargs
) -> list[float]:
    """First ``n_modes`` bending frequencies (Hz) of ``BulletBackend`` (``kwargs``) linearised
    at the static equilibrium under ``tension`` (N) on every cable."""
    from cdcr_gym.backends.bullet import BulletBackend

    params = RobotParams.preset(name)
    be = BulletBackend(params, gravity=gravity, **kwargs)
    t = np.full(params.n_cables, tension)
    be.reset(t[None])
    q0 = be.joint_positions
    n = q0.size

    def force(q: np.ndarray) -> np.ndarray:
        be.set_joint_state(q)
        f = be.cable_generalized_forces(t) - be.stiffness * q
        return f + be.gravity_generalized_forces() if gravity else f

    eps = 1e-6
    stiff = np.empty((n, n))
    for i in range(n):
        dq = np.zeros(n)
        dq[i] = eps
        stiff[:, i] = -(force(q0 + dq) - force(q0 - dq)) / (2.0 * eps)
    be.set_joint_state(q0)
    mass = be.mass_matrix()
    be.close()
    w, _ = _eig(stiff, mass)
    return _bending_pairs(w, np.zeros(w.size), n_modes)


def fit_damped_sinusoid(t: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """(ω rad/s, ζ) of x(t) ≈ A·e^(−ζωt)·cos(ω·√(1−ζ²)·t + φ) + c, ζ < 1, least squares."""
    x = np.asarray(x, float)
    spec = np.abs(np.fft.rfft(x - x[-1], n=16 * x.size))
    freqs = np.fft.rfftfreq(16 * x.size, t[1] - t[0])
    w0 = 2.0 * math.pi * max(freqs[1 + np.argmax(spec[1:])], 1.0 / (t[-1] - t[0]))

    def model(tt, a, w, z, phi, c):
        wd = w * math.sqrt(max(1.0 - z * z, 1e-12))
        return a * np.exp(-z * w * tt) * np.cos(wd * tt + phi) + c

    best = None
    for z0 in (0.02, 0.1, 0.3, 0.6):
        try:
            popt, _ = scipy.optimize.curve_fit(
                model,
                t,
                x,
                p0=(x[0] - x[-1], w0, z0, 0.0, x[-1]),
                bounds=(
                    [-np.inf, 0.0, 0.0, -np.pi, -np.inf],
                    [np.inf, np.inf, 0.999, np.pi, np.inf],
                ),
                maxfev=20000,
            )
        except RuntimeError:
            continue
        res = float(np.sum((model(t, *popt) - x) ** 2))
        if best is None or res < best[0]:
            best = (res, popt)
    assert best is not None
    return float(best[1][1]), float(best[1][2])


def free_vibration(
    backend: str,
    name: str,
    damping_ratio: float,
    physics_timestep: float | None = None,
    gravity: bool = False,
    duration: float | None = None,
) -> dict:
    """Release a robot bent by 5 % of ``max_tension`` on cable 0 (cables then slack) and fit
    the tip's deflection (along the initial one) with a damped sinusoid: the first mode's
    frequency (Hz) and damping ratio as the backend produces them."""
    params = RobotParams.preset(name)
    kw: dict = {"gravity": gravity, "damping_ratio": damping_ratio}
    if physics_timestep is not None:
        kw["physics_timestep"] = physics_timestep
        kw["control_timestep"] = physics_timestep
    head = {
        "backend": backend,
        "robot": name,
        "damping_ratio_set": damping_ratio,
        "timestep_s": kw.get("physics_timestep", 0.02 if backend == "mujoco" else 0.01),
        "gravity": gravity,
    }
    try:
        if backend == "mujoco":
            from cdcr_gym.backends.mujoco import MuJoCoBackend

            be = MuJoCoBackend(params, **kw)
        else:
            from cdcr_gym.backends.bullet import BulletBackend

            kw.setdefault("control_timestep", be_default := 0.01)
            kw.setdefault("physics_timestep", be_default)
            be = BulletBackend(params, **kw)
    except ValueError as err:  # a ζ below what the step delivers: refused by name
        return {**head, "refused": str(err), "frequency_hz": None, "damping_ratio_fit": None}
    pull = np.zeros((1, params.n_cables))
    pull[0, 0] = 0.05 * params.max_tension
    be.reset(pull)
    tip0 = be.read().tip[0].copy()
    be.reset(np.zeros_like(pull))
    rest = be.read().tip[0].copy()
    axis = (tip0 - rest) / np.linalg.norm(tip0 - rest)
    be.reset(pull)
    dt = be.control_timestep
    if duration is None:
        duration = 4.0 / max(damping_ratio, 0.05)  # a few first-mode periods of decay (≈ 3 Hz)
    n = int(round(duration / dt))
    x = [float((tip0 - rest) @ axis)]
    zero = np.zeros_like(pull)
    from cdcr_gym.backends.base import SimulationDivergedError

    result = {
        "backend": backend,
        "robot": name,
        "damping_ratio_set": damping_ratio,
        "timestep_s": dt,
        "gravity": gravity,
    }
    try:
        for _ in range(n):
            be.apply_tensions(zero)
            x.append(float((be.read().tip[0] - rest) @ axis))
    except SimulationDivergedError as err:
        return {**result, "diverged": str(err), "frequency_hz": None, "damping_ratio_fit": None}
    finally:
        be.close()
    t = dt * np.arange(n + 1)
    w, z = fit_damped_sinusoid(t, np.asarray(x))
    return {
        "backend": backend,
        "robot": name,
        "damping_ratio_set": damping_ratio,
        "timestep_s": dt,
        "gravity": gravity,
        "frequency_hz": w / (2.0 * math.pi),
        "damping_ratio_fit": z,
    }


def _pct(value: float, ref: float) -> float:
    return 100.0 * (value - ref) / ref


def run(quick: bool = False) -> dict:  # pragma: no cover (the CLI; tests call the pieces)
    ref = json.loads(REFERENCE.read_text())
    robots = ("paper",) if quick else ("paper", "tdcr2", "ftdcr_v4")
    rows = []
    for name in robots:
        params = RobotParams.preset(name)
        for cables, tension in (("slack", 0.0), ("taut", 0.5 * params.max_tension)):
            for grav in (False, True):
                key = f"{cables}_gravity_{'on' if grav else 'off'}"
                row = {
                    "robot": name,
                    "case": key,
                    "reference_hz": ref["robots"][name]["cases"][key]["frequencies_hz"],
                    "mujoco_hz": mujoco_linearised(name, grav, tension),
                    "bullet_hz": bullet_linearised(name, grav, tension),
                }
                rows.append(row)
                r, m, b = row["reference_hz"], row["mujoco_hz"], row["bullet_hz"]
                print(
                    f"{name:9s} {key:17s} ref {r[0]:7.3f} {r[1]:7.3f} | MuJoCo {m[0]:7.3f} "
                    f"({_pct(m[0], r[0]):+5.1f} %) {m[1]:7.3f} ({_pct(m[1], r[1]):+5.1f} %) | "
                    f"bullet {b[0]:7.3f} ({_pct(b[0], r[0]):+5.1f} %) {b[1]:7.3f} "
                    f"({_pct(b[1], r[1]):+5.1f} %)",
                    flush=True,
                )
    # links per span: the discretisation's share (MuJoCo, slack, no gravity)
    refinement = []
    for name in robots:
        r = ref["robots"][name]["cases"]["slack_gravity_off"]["frequencies_hz"]
        for m in (1, 2, 4):
            f = mujoco_linearised(name, False, 0.0, links_per_span=m)
            refinement.append({"robot": name, "links_per_span": m, "mujoco_hz": f})
            print(
                f"{name:9s} links_per_span={m}: {f[0]:7.3f} ({_pct(f[0], r[0]):+5.2f} %) "
                f"{f[1]:7.3f} ({_pct(f[1], r[1]):+5.2f} %)",
                flush=True,
            )
    damping = []
    cases = [
        (backend, "paper", zeta, dt, False)
        for backend in ("mujoco", "bullet")
        for zeta in (0.05, 0.3, 0.7)
        for dt in (None, 0.005, 0.001)
    ]
    if not quick:  # gravity: taken into account (ζ₁ of the mode with gravity)
        cases += [
            (backend, name, 0.05, 0.001, True)
            for backend in ("mujoco", "bullet")
            for name in ("paper", "tdcr2", "ftdcr_v4")
        ]
    for backend, name, zeta, dt, grav in cases:
        res = free_vibration(backend, name, zeta, physics_timestep=dt, gravity=grav)
        damping.append(res)
        head = (
            f"{backend:6s} {name:8s} g={int(grav)} ζ = {zeta:4.2f} dt = {res['timestep_s']:.3f} s:"
        )
        if res["frequency_hz"] is None:
            print(head, "refused" if "refused" in res else "diverged", flush=True)
            continue
        print(
            f"{head} f1 = {res['frequency_hz']:6.3f} Hz, ζ_fit = {res['damping_ratio_fit']:.3f} "
            f"({_pct(res['damping_ratio_fit'], zeta):+.1f} %)",
            flush=True,
        )
    return {
        "command": "python -m experiments.dynamics_check",
        "frequencies": rows,
        "links_per_span": refinement,
        "free_vibration": damping,
    }


def main(argv: list[str] | None = None) -> None:  # pragma: no cover
    json_main(
        "python -m experiments.dynamics_check",
        __doc__,
        "experiments/dynamics/check.json",
        "the paper robot only",
        run,
        argv,
    )


if __name__ == "__main__":  # pragma: no cover
    main()
