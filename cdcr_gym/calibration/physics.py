"""Physics replay of tendon-displacement measurements: a physics backend (MuJoCo, pybullet)
driven through the rows in order with their recorded timing, for many parameter sets at once.

Timing (SI, seconds): the rows' ``timestamps`` t_m. The first row's displacements are held for
``first_hold`` from rest (the straight robot, the drives at their pretension); for every later
row the commands ramp linearly from the previous row's over the recorded gap t_m − t_{m−1},
in control steps of the backend's ``control_timestep``, and the tip is read at the end of the
ramp (the row's time). A gap longer than ``max_gap`` (the robot paused between motion
patterns; the v4 files have gaps up to 16 s) is shortened to ``max_gap``: the robot is at rest
by then, so the longer hold changes nothing but the cost. Without timestamps every gap is
``default_gap``. The state carries over from row to row (warm start): the friction state of
the cables (loading vs unloading) and any motion not yet settled act as on the robot.

Parameters (names of :mod:`cdcr_gym.calibration.parameters`):

* simulated per robot: ``youngs_modulus``, ``friction_coefficient``, ``tip_payload``,
  ``backbone_friction`` (MuJoCo), the
  tendon drive's ``tendon_stiffness*`` / ``tendon_pretension*`` (the drive law of
  ``cdcr_gym.model.tendons`` with these k and T0), ``base_compliance``, ``drive_backlash``
  and ``drive_softening`` (each robot's commands through its drives' backlash, then their
  softening), and, with gravity,
  the base tilt
  (``base_tilt_x``, ``base_tilt_y``): gravity acts along the measurement frame's −Z, i.e. along
  Rᵀ·(0, 0, −g) in the robot's base frame;
* applied to the simulated tips (no simulation): the base frame — ``tip = R·(p + marker·t) +
  t_base``, R = Rz(yaw)·Ry(tilt_y)·Rx(tilt_x), p and t the simulated tip and tangent in the
  robot's base frame — and the marker offset.

The drives pull with the law of the tendon drive ``drive``, capped at its ``max_tension``
(none by default, as the constant-curvature replay), not at the robot's ``max_tension``: that
is the range of tension commands and actions, not a limit of the measured drives
(``Backend.set_drive_max_tension``).

The robot's geometry (section lengths, tendon radii and angles) is the one of ``base``; a
calibration starts from a CCKA fit's ``params.yaml`` that holds the fitted geometry.

:meth:`PhysicsReplay.batch` simulates B parameter sets: the sets that differ only in the frame
share one simulated robot, the others are robots of ONE batched MuJoCo model (each with its own
MjModel parameters: ``MuJoCoBackend.set_randomized`` and ``set_drive_parameters``) stepped
together, so a forward-difference Jacobian of p parameters is one replay of at most p + 1
robots. Other backends (pybullet) build one backend per distinct robot and replay them in turn.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.data import Measurements
from cdcr_gym.calibration.drive import TendonDrive, rotation_zyx
from cdcr_gym.calibration.parameters import accepts
from cdcr_gym.model.drive_softening import soften
from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams

__all__ = ["FRAME_NAMES", "PhysicsReplay", "ReplayTiming", "row_steps"]

#: Names applied to the simulated tips (no simulation needed).
FRAME_NAMES = frozenset(
    {"base_x", "base_y", "base_z", "base_yaw", "base_tilt_x", "base_tilt_y", "marker_offset"}
)
#: Names the physics displacement replay simulates (besides the tendon drive's).
ROBOT_NAMES = frozenset(
    {"youngs_modulus", "friction_coefficient", "tip_payload", "backbone_friction"}
)


def physics_name(name: str) -> bool:
    """Whether the physics displacement replay can fit ``name``."""
    return (
        name in FRAME_NAMES
        or name in ROBOT_NAMES
        or name.startswith("tendon_")
        or name in ("base_compliance", "drive_backlash", "drive_softening")
    )


def row_steps(
    timestamps: np.ndarray | None,
    n_rows: int,
    control_timestep: float,
    *,
    first_hold: float = 2.0,
    max_gap: float = 1.0,
    default_gap: float = 0.5,
) -> np.ndarray:
    """Control steps (M,) int >= 1 spent on each row (module docstring): the first row
    ``first_hold`` s, every later one its gap to the previous row capped at ``max_gap`` s
    (``default_gap`` without timestamps; a non-increasing timestamp gives one step)."""
    if n_rows == 0:
        return np.zeros(0, dtype=int)
    if timestamps is None:
        gaps = np.full(n_rows, default_gap)
    else:
        ts = np.asarray(timestamps, dtype=np.float64)
        gaps = np.concatenate([[0.0], np.diff(ts)])
    gaps = np.clip(gaps, 0.0, max_gap)
    gaps[0] = first_hold
    return np.maximum(1, np.rint(gaps / control_timestep).astype(int))


@dataclass
class ReplayTiming:
    """Where a replay's time went (s): building the backends, stepping, reading/other."""

    build: float = 0.0
    step: float = 0.0
    robots: int = 0
    robot_steps: int = 0
    calls: int = 0
    history: list[tuple[int, float, float]] = field(default_factory=list)

    def add(self, robots: int, steps: int, build: float, step: float) -> None:
        self.build += build
        self.step += step
        self.robots += robots
        self.robot_steps += robots * steps
        self.calls += 1
        self.history.append((robots, build, step))

    def summary(self) -> dict[str, float]:
        per = self.step / self.robot_steps if self.robot_steps else float("nan")
        return {
            "replays": self.calls,
            "robots_simulated": self.robots,
            "build_s": round(self.build, 3),
            "step_s": round(self.step, 3),
            "ms_per_robot_control_step": round(per * 1e3, 4),
        }


class PhysicsReplay:
    """A physics backend driven by the rows' displacements in order (module docstring).

    Args:
        data: displacement measurements (with ``timestamps`` if recorded).
        base: the robot (its geometry; k, T0 and E are replaced by fitted values).
        drive: the robot's nominal tendon drive (k, T0 of the parameters not fitted).
        backend: "mujoco" or "bullet" (or a backend class).
        backend_kwargs: fixed keyword arguments of the backend (``gravity``,
            ``control_timestep``, ``physics_timestep``, ``threads``, ...).
        first_hold, max_gap, default_gap: the timing (s, module docstring).
        slack: False: the linear drive law T0 + k·(d − s) without the clamp at 0 (MuJoCo, an
            ablation; the drives' damping then stays on every tendon).
        stiffness_scale: multiplies every tendon stiffness k (an ablation: stiff tendons).
        gate_damping: MuJoCo: the drives' damping on the (nearly) taut tendons only
            (``TendonDrives.gate_damping``: a slack tendon's damping makes the robot lag the
            commands by ~0.5 s, a simulation artefact the real robot does not have).

    Raises:
        ValueError: for tension data, a backend without displacement control, an argument
            the backend does not take, or a non-positive time.
    """

    def __init__(
        self,
        data: Measurements,
        base: RobotParams,
        drive: TendonDrive,
        backend: Any = "mujoco",
        backend_kwargs: dict | None = None,
        *,
        first_hold: float = 2.0,
        max_gap: float = 1.0,
        default_gap: float = 0.5,
        gate_damping: bool = True,
        slack: bool = True,
        stiffness_scale: float = 1.0,
    ) -> None:
        from cdcr_gym.calibration.simulate import backend_class

        if data.displacements is None:
            raise ValueError("PhysicsReplay needs displacement data (use BackendReplay)")
        self.cls = backend_class(backend) if isinstance(backend, str) else backend
        if self.cls is None or not getattr(self.cls, "supports_displacement_control", False):
            raise ValueError(f"backend {backend!r} cannot replay displacement data")
        self.name = backend if isinstance(backend, str) else self.cls.__name__
        self.data = data
        self.base = base
        self.drive = drive
        self.fixed = dict(backend_kwargs or {})
        for key in self.fixed:
            if not accepts(self.cls, key):
                raise ValueError(f"the {self.name} backend has no argument {key!r}")
        for label, v in (("first_hold", first_hold), ("max_gap", max_gap)):
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ValueError(f"{label} must be > 0 s, got {v!r}")
        import inspect

        default_ct = inspect.signature(self.cls.__init__).parameters["control_timestep"].default
        self.control_timestep = float(self.fixed.get("control_timestep", default_ct))
        self.steps = row_steps(
            data.timestamps,
            len(data),
            self.control_timestep,
            first_hold=first_hold,
            max_gap=max_gap,
            default_gap=default_gap,
        )
        self.gravity = bool(self.fixed.get("gravity", True))
        self.timing = ReplayTiming()
        self.batched = getattr(self.cls, "__name__", "") == "MuJoCoBackend"
        #: MuJoCo: the drives' damping only on (nearly) taut tendons (``TendonDrives.gate_damping``)
        self.gate_damping = bool(gate_damping) and bool(slack)
        #: False (MuJoCo, an ablation): the linear drive law, tendons push when slack
        self.slack = bool(slack)
        if not (np.isfinite(stiffness_scale) and stiffness_scale > 0):
            raise ValueError(f"stiffness_scale must be > 0, got {stiffness_scale!r}")
        #: multiplies every tendon stiffness (an ablation: the stiff-tendon limit)
        self.stiffness_scale = float(stiffness_scale)
        if not self.slack and not self.batched:
            raise ValueError("slack=False (the linear drive law) needs the MuJoCo backend")

    # -- values → robots ------------------------------------------------------------------------
    def drive_of(self, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """k (C,) N/m and T0 (C,) N of ``values`` (the drive's where not fitted)."""
        from cdcr_gym.calibration.simulate import drive_geometry

        g = drive_geometry(self.base, self.drive, [values], stiffness_scale=self.stiffness_scale)
        return g.stiffness[0], np.maximum(g.pretension[0], 0.0)

    def base_compliance_of(self, values: dict[str, float]) -> float:
        """The compliant base c (m/N) of ``values`` (the drive's where not fitted)."""
        return float(values.get("base_compliance", self.drive.base_compliance))

    def commands_of(self, values: dict[str, float]) -> np.ndarray:
        """The pulls (M, C) m that reach the tendons of ``values``' robot: the rows' commands
        through its drives' backlash (``drive_backlash``; :func:`cdcr_gym.calibration.backlash.play`)
        and softening (``drive_softening``; :func:`cdcr_gym.model.drive_softening.soften`), the
        drive's where not fitted."""
        d = self.data.displacements
        assert d is not None
        played = play(d, float(values.get("drive_backlash", self.drive.backlash)))
        return soften(played, float(values.get("drive_softening", self.drive.softening)))

    def _key(self, values: dict[str, float]) -> tuple:
        """What the simulation of ``values`` depends on (frame names excluded, except the
        tilt under gravity)."""
        k, t0 = self.drive_of(values)
        extra = tuple(
            round(float(values.get(n, 0.0)), 15)
            for n in ("base_tilt_x", "base_tilt_y")
            if self.gravity
        )
        return (
            float(values.get("youngs_modulus", self.base.youngs_modulus)),
            float(
                values.get("friction_coefficient", self.fixed.get("friction_coefficient") or 0.0)
            ),
            float(values.get("tip_payload", self.fixed.get("tip_payload") or 0.0)),
            float(values.get("backbone_friction", self.fixed.get("backbone_friction") or 0.0)),
            tuple(k.tolist()),
            tuple(t0.tolist()),
            self.base_compliance_of(values),
            float(values.get("drive_backlash", self.drive.backlash)),
            float(values.get("drive_softening", self.drive.softening)),
            extra,
        )

    def _gravity_in_base(self, values: dict[str, float]) -> np.ndarray:
        rot = rotation_zyx(
            np.array([0.0]),
            np.array([values.get("base_tilt_y", 0.0)]),
            np.array([values.get("base_tilt_x", 0.0)]),
        )[0]
        return rot.T @ np.array([0.0, 0.0, -STANDARD_GRAVITY])

    # -- simulation -----------------------------------------------------------------------------
    def simulate(self, robots: list[dict[str, float]]) -> tuple[np.ndarray, np.ndarray, float]:
        """Tips (R, M, 3) m and tangents (R, M, 3) in the robot's base frame of R robots, and
        the largest tip motion (m) over the last control step of any row."""
        if self.batched:
            return self._simulate_batched(robots)
        tips, dirs, moved = [], [], 0.0
        for v in robots:
            t, d, m = self._simulate_one(v)
            tips.append(t)
            dirs.append(d)
            moved = max(moved, m)
        return np.stack(tips), np.stack(dirs), moved

    def _drive_loop(
        self, backend: Any, commands: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """Replay the rows (module docstring) with robot i's commands ``commands[i]`` (n, M, C)
        m; its tips and tangents (n, M, 3) and the largest last-step tip motion (m)."""
        d = commands
        n, m_rows = d.shape[0], d.shape[1]
        tips = np.empty((n, m_rows, 3))
        dirs = np.empty((n, m_rows, 3))
        moved = 0.0
        previous = d[:, 0]
        for m in range(m_rows):
            target = d[:, m]
            steps = int(self.steps[m])
            before = None
            for k in range(1, steps + 1):
                if k == steps:
                    before = backend.read().tip.copy()
                cmd = target if m == 0 else previous + (target - previous) * (k / steps)
                backend.apply_displacements(np.ascontiguousarray(cmd))
            r = backend.read()
            tips[:, m] = r.tip
            dirs[:, m] = r.tip_direction
            if before is not None:
                moved = max(moved, float(np.max(np.linalg.norm(r.tip - before, axis=1))))
            previous = target
        return tips, dirs, moved

    def _simulate_batched(
        self, robots: list[dict[str, float]]
    ) -> tuple[np.ndarray, np.ndarray, float]:
        t0 = time.perf_counter()
        n = len(robots)
        kw = dict(self.fixed)
        kw.pop("friction_coefficient", None)
        kw.pop("tip_payload", None)
        kw.pop("backbone_friction", None)
        params = self.base
        backend = self.cls(params=params, num_robots=n, **kw)
        try:
            idx = np.arange(n)
            rand: dict[str, np.ndarray] = {}
            e = np.array([v.get("youngs_modulus", params.youngs_modulus) for v in robots])
            if np.any(e != params.youngs_modulus):
                rand["youngs_modulus"] = e
            mu0 = float(self.fixed.get("friction_coefficient", 0.0))
            mu = np.array([v.get("friction_coefficient", mu0) for v in robots])
            if np.any(mu > 0.0):
                rand["friction_coefficient"] = mu
            p0 = float(self.fixed.get("tip_payload", 0.0))
            pay = np.array([v.get("tip_payload", p0) for v in robots])
            if np.any(pay > 0.0):
                rand["tip_payload"] = pay
            f0 = float(self.fixed.get("backbone_friction", 0.0))
            bb = np.array([v.get("backbone_friction", f0) for v in robots])
            if np.any(bb > 0.0):
                rand["backbone_friction"] = bb
            if rand:
                backend.set_randomized(idx, rand)
            if self.gravity:
                for i, v in enumerate(robots):
                    if v.get("base_tilt_x", 0.0) or v.get("base_tilt_y", 0.0):
                        backend._own_model(i).opt.gravity[:] = self._gravity_in_base(v)
            backend.gate_damping = self.gate_damping
            drives = [self.drive_of(v) for v in robots]
            backend.set_drive_parameters(
                idx,
                np.stack([k for k, _ in drives]),
                np.stack([t for _, t in drives]),
                np.array([self.base_compliance_of(v) for v in robots]),
            )
            backend.set_drive_max_tension(self.drive.max_tension)
            if not self.slack:
                for i in range(n):  # the drives may push up to max_tension: the linear law
                    model = backend._own_model(i)
                    model.actuator_forcerange[backend._drive_slice, 1] = params.max_tension
            t1 = time.perf_counter()
            commands = np.stack([self.commands_of(v) for v in robots])
            tips, dirs, moved = self._drive_loop(backend, commands)
        finally:
            backend.close()
        t2 = time.perf_counter()
        self.timing.add(n, int(self.steps.sum()), t1 - t0, t2 - t1)
        return tips, dirs, moved

    def _simulate_one(self, v: dict[str, float]) -> tuple[np.ndarray, np.ndarray, float]:
        from cdcr_gym.calibration.parameters import tilt_quaternion

        t0 = time.perf_counter()
        k, t_pre = self.drive_of(v)
        params = replace(
            self.base,
            youngs_modulus=v.get("youngs_modulus", self.base.youngs_modulus),
            tendon_stiffness=tuple(k.tolist()),
            tendon_pretension=tuple(t_pre.tolist()),
            base_compliance=self.base_compliance_of(v),
        )
        kw = dict(self.fixed)
        for key in ("friction_coefficient", "tip_payload", "backbone_friction"):
            if key in v:
                kw[key] = float(v[key])
        if self.gravity and (v.get("base_tilt_x", 0.0) or v.get("base_tilt_y", 0.0)):
            kw["base_orientation"] = tilt_quaternion(v)
        backend = self.cls(params=params, **kw)
        if hasattr(backend, "gate_damping"):
            backend.gate_damping = self.gate_damping
        backend.set_drive_max_tension(self.drive.max_tension)
        try:
            t1 = time.perf_counter()
            tips, dirs, moved = self._drive_loop(backend, self.commands_of(v)[None])
        finally:
            backend.close()
        self.timing.add(1, int(self.steps.sum()), t1 - t0, time.perf_counter() - t1)
        return tips[0], dirs[0], moved

    # -- the frame ------------------------------------------------------------------------------
    @staticmethod
    def frame(
        values: dict[str, float], tip: np.ndarray, direction: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Base-frame tips (M, 3) and tangents in the measurement frame (module docstring)."""
        rot = rotation_zyx(
            np.array([values.get("base_yaw", 0.0)]),
            np.array([values.get("base_tilt_y", 0.0)]),
            np.array([values.get("base_tilt_x", 0.0)]),
        )[0]
        p = tip + values.get("marker_offset", 0.0) * direction
        shift = np.array([values.get(n, 0.0) for n in ("base_x", "base_y", "base_z")])
        return p @ rot.T + shift, direction @ rot.T

    def batch(self, batch: list[dict[str, float]]) -> tuple[np.ndarray, np.ndarray, float]:
        """Tips and tangents (B, M, 3) in the measurement frame of B value sets, the distinct
        robots among them simulated together; and the largest last-step tip motion (m)."""
        keys = [self._key(v) for v in batch]
        unique: dict[tuple, int] = {}
        robots: list[dict[str, float]] = []
        for key, v in zip(keys, batch):
            if key not in unique:
                unique[key] = len(robots)
                robots.append(v)
        tips, dirs, moved = self.simulate(robots)
        out_t = np.empty((len(batch), len(self.data), 3))
        out_d = np.empty_like(out_t)
        for b, (key, v) in enumerate(zip(keys, batch)):
            r = unique[key]
            out_t[b], out_d[b] = self.frame(v, tips[r], dirs[r])
        return out_t, out_d, moved

    def backend_kwargs(self, values: dict[str, float]) -> dict[str, Any]:
        """The backend's keyword arguments for ``values``: the fixed ones plus the fitted
        friction, payload, (with gravity) the base tilt as ``base_orientation`` and, on
        MuJoCo, ``gate_damping`` as replayed."""
        from cdcr_gym.calibration.parameters import tilt_quaternion

        kw = dict(self.fixed)
        for key in ("friction_coefficient", "tip_payload", "backbone_friction"):
            if key in values:
                kw[key] = float(values[key])
        if "base_tilt_x" in values or "base_tilt_y" in values:
            kw["base_orientation"] = tilt_quaternion(values)
        if self.batched and self.gate_damping:
            kw["gate_damping"] = True  # as replayed: an env of this robot gates them too
        return kw

    def __call__(self, values: dict[str, float]) -> Any:
        from cdcr_gym.calibration.simulate import Prediction

        tip, direction, moved = self.batch([values])
        return Prediction(tip[0], direction[0], moved)
