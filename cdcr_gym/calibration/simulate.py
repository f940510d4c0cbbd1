"""Forward models for a calibration: the tips a robot with given parameters reaches under the
measured tensions, replayed in measurement order.

* :class:`AnalyticReplay` — the CCKA/PCC model (``AnalyticBackend.equilibrium``), all rows in
  one batched call. Quasi-static and frictionless: the order of the rows does not matter.
* :class:`BackendReplay` — any :class:`~cdcr_gym.backends.base.Backend` (pybullet, MuJoCo)
  built from the candidate parameters and driven through the rows in order: it starts at rest
  with slack cables (``reset``), then for every row ramps the tensions linearly from the
  previous row's over ``ramp_steps`` control steps (slowly, as weights are hung on a cable) and
  holds them for ``settle_steps`` more, and reads the tip. Each row's static solve is thus the
  dynamics relaxing to rest, warm-started from the previous row's state, so the friction state
  of the cables (loading vs unloading) carries from row to row as it did on the robot.

Both return the tips in the measurement frame (the base tilt applied) and the tip tangents.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.data import Measurements
from cdcr_gym.calibration.drive import (
    DriveGeometry,
    TendonDrive,
    forward_tips,
    rotation_zyx,
    solve_drive,
)
from cdcr_gym.calibration.parameters import accepts, robot_with, tilt_matrix, tilt_quaternion
from cdcr_gym.model.drive_softening import soften
from cdcr_gym.model.params import RobotParams

__all__ = [
    "BACKENDS",
    "backend_class",
    "AnalyticReplay",
    "BackendReplay",
    "DriveReplay",
    "drive_geometry",
    "Prediction",
]

#: Backend name → "module:class" of the physics backends (imported when used).
BACKENDS = {
    "bullet": "cdcr_gym.backends.bullet:BulletBackend",
    "mujoco": "cdcr_gym.backends.mujoco:MuJoCoBackend",
}


def backend_class(name: str) -> Any:
    """The class of backend ``name`` ("analytic" → None; "bullet", "mujoco").

    Raises:
        ValueError: for an unknown name, or a backend this installation does not have.
    """
    if name in ("analytic", "ccka"):
        return None
    if name not in BACKENDS:
        raise ValueError(f"backend must be one of {['analytic', *BACKENDS]}, got {name!r}")
    module, attribute = BACKENDS[name].split(":")
    try:
        return getattr(importlib.import_module(module), attribute)
    except (ImportError, AttributeError) as exc:
        raise ValueError(
            f"the {name} backend ({BACKENDS[name]}) is not available here: {exc}"
        ) from None


@dataclass
class Prediction:
    """Predicted tips (M, 3) m and tangents (M, 3) in the measurement frame; ``unsettled``: the
    largest tip motion (m) over the last control step of any row (0 for a static model)."""

    tip: np.ndarray
    tip_direction: np.ndarray
    unsettled: float = 0.0


class AnalyticReplay:
    """The CCKA/PCC prediction of every row at once (no gravity, no friction, no payload)."""

    name = "analytic"

    def __init__(self, data: Measurements, base: RobotParams, backend_kwargs: dict | None = None):
        if backend_kwargs:
            raise ValueError(
                f"the analytic backend takes no backend arguments, got {sorted(backend_kwargs)}"
            )
        self.data = data
        self.base = base

    def backend_kwargs(self, values: dict[str, float]) -> dict[str, Any]:
        """Keyword arguments of the backend for ``values`` (none for the analytic model)."""
        return {}

    def __call__(self, values: dict[str, float]) -> Prediction:
        from cdcr_gym.backends.analytic import AnalyticBackend

        params = robot_with(self.base, values)
        r = AnalyticBackend(params).equilibrium(self.data.tensions)
        rot = tilt_matrix(values)
        return Prediction(r.tip @ rot.T, r.tip_direction @ rot.T)


class BackendReplay:
    """A physics backend driven through the rows in order (module docstring).

    Args:
        data: the measurements (their tensions and order).
        base: the nominal robot (the fitted robot parameters replace its values).
        backend: backend name ("bullet", "mujoco") or a Backend class.
        backend_kwargs: fixed keyword arguments of the backend (e.g. ``gravity``,
            ``links_per_span``); the fitted ``friction_coefficient``, ``tip_payload`` and base
            tilt (``base_orientation``) are added per evaluation.
        ramp_steps: control steps over which a row's tensions are ramped from the previous row's.
        settle_steps: control steps they are then held before the tip is read.
    """

    def __init__(
        self,
        data: Measurements,
        base: RobotParams,
        backend: Any = "bullet",
        backend_kwargs: dict | None = None,
        ramp_steps: int = 25,
        settle_steps: int = 100,
    ) -> None:
        self.cls = backend_class(backend) if isinstance(backend, str) else backend
        self.name = backend if isinstance(backend, str) else getattr(backend, "__name__", "backend")
        self.data = data
        self.base = base
        self.fixed = dict(backend_kwargs or {})
        for key in self.fixed:
            if not accepts(self.cls, key):
                raise ValueError(f"the {self.name} backend has no argument {key!r}")
        for name, value in (("ramp_steps", ramp_steps), ("settle_steps", settle_steps)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        self.ramp_steps = int(ramp_steps)
        self.settle_steps = int(settle_steps)

    def backend_kwargs(self, values: dict[str, float]) -> dict[str, Any]:
        """The backend's keyword arguments for ``values``: the fixed ones plus the fitted
        friction, payload and tilt."""
        kw = dict(self.fixed)
        for key in ("friction_coefficient", "tip_payload", "backbone_friction"):
            if key in values:
                kw[key] = float(values[key])
        if ("base_tilt_x" in values or "base_tilt_y" in values) and accepts(
            self.cls, "base_orientation"
        ):
            kw["base_orientation"] = tilt_quaternion(values)
        return kw

    def __call__(self, values: dict[str, float]) -> Prediction:
        params = robot_with(self.base, values)
        backend = self.cls(params=params, **self.backend_kwargs(values))
        try:
            tips, dirs, moved = [], [], 0.0
            previous = np.zeros(params.n_cables)
            backend.reset(previous[None])
            for target in self.data.tensions:
                for k in range(1, self.ramp_steps + 1):
                    backend.apply_tensions(
                        (previous + (target - previous) * (k / self.ramp_steps))[None]
                    )
                before = backend.read().tip[0]
                for _ in range(self.settle_steps):
                    before = backend.read().tip[0]
                    backend.apply_tensions(target[None])
                r = backend.read()
                moved = max(moved, float(np.linalg.norm(r.tip[0] - before)))
                tips.append(r.tip[0])
                dirs.append(r.tip_direction[0])
                previous = target
        finally:
            backend.close()
        tip, direction = np.array(tips), np.array(dirs)
        if "base_tilt_x" in values or "base_tilt_y" in values:
            # the backend reports R0 of the (tilted) base; with base_orientation it also tilted
            # gravity, else the tilt is a frame rotation only
            rot = tilt_matrix(values)
            tip, direction = tip @ rot.T, direction @ rot.T
        return Prediction(tip, direction, moved)


def drive_geometry(
    base: RobotParams,
    drive: TendonDrive | None,
    batch: list[dict[str, float]],
    *,
    slack: bool = True,
    stiffness_scale: float = 1.0,
) -> DriveGeometry:
    """The arrays of :class:`~cdcr_gym.calibration.drive.DriveGeometry` for a batch of value
    sets (SI; names of :mod:`cdcr_gym.calibration.parameters`); unset values are the robot's
    and the drive's. ``stiffness_scale`` multiplies every k (the rigid-tendon ablation)."""
    s, c = base.n_sections, base.n_cables
    owner = np.asarray(base.cable_section)
    b = len(batch)
    lengths = np.empty((b, s))
    radii = np.empty((b, c))
    angles = np.empty((b, c))
    ei = np.empty(b)
    k = np.empty((b, c))
    t0 = np.empty((b, c))
    yaw, tx, ty = np.zeros(b), np.zeros(b), np.zeros(b)
    trans = np.zeros((b, 3))
    marker = np.zeros(b)
    comp = np.zeros(b)
    pitch = np.zeros(b)
    k_nom = np.array(drive.stiffness) if drive is not None else np.ones(c)
    t_nom = np.array(drive.pretension) if drive is not None else np.zeros(c)
    sec_len = np.array(base.section_lengths)
    sec_r = np.array([sec.cable_radius for sec in base.sections])
    beta = np.array(base.cable_angles)
    moment = base.second_moment_of_area
    for n, v in enumerate(batch):
        ell = sec_len.copy()
        r = sec_r + (v.get("cable_radius", sec_r.max()) - sec_r.max())
        ang = beta.copy()
        kk, tt = k_nom.copy(), t_nom.copy()
        for j in range(s):
            ell[j] = v.get(f"length_s{j + 1}", ell[j])
            r[j] = v.get(f"cable_radius_s{j + 1}", r[j])
            ang[owner == j] += v.get(f"section_angle_s{j + 1}", 0.0)
            for q, arr in (("tendon_stiffness", kk), ("tendon_pretension", tt)):
                if f"{q}_s{j + 1}" in v:
                    arr[owner == j] = v[f"{q}_s{j + 1}"]
        for i in range(c):
            ang[i] += v.get(f"cable_angle_{i + 1}", 0.0)
            kk[i] = v.get(f"tendon_stiffness_{i + 1}", kk[i])
            tt[i] = v.get(f"tendon_pretension_{i + 1}", tt[i])
        if "tendon_stiffness" in v:
            kk[:] = v["tendon_stiffness"]
        if "tendon_pretension" in v:
            tt[:] = v["tendon_pretension"]
        lengths[n], radii[n], angles[n] = ell, r[owner], ang
        k[n], t0[n] = kk * stiffness_scale, tt
        ei[n] = v.get("youngs_modulus", base.youngs_modulus) * moment
        yaw[n] = v.get("base_yaw", 0.0)
        tx[n], ty[n] = v.get("base_tilt_x", 0.0), v.get("base_tilt_y", 0.0)
        trans[n] = [v.get("base_x", 0.0), v.get("base_y", 0.0), v.get("base_z", 0.0)]
        marker[n] = v.get("marker_offset", 0.0)
        comp[n] = v.get("base_compliance", drive.base_compliance if drive is not None else 0.0)
        pitch[n] = v.get("cable_pitch", base.cable_pitch)
    return DriveGeometry(
        lengths=lengths,
        section_of=owner,
        radii=radii,
        angles=angles,
        ei=ei,
        stiffness=k,
        pretension=t0,
        max_tension=drive.max_tension if drive is not None else np.inf,
        base_compliance=comp,
        slack=slack,
        base_rotation=rotation_zyx(yaw, ty, tx),
        base_translation=trans,
        marker=marker,
        pitch=pitch,
    )


class DriveReplay:
    """The CCKA model of every row at once, driven by the rows' displacements (through the
    tendon drive law) or their tensions, with a base frame and a marker offset
    (:mod:`cdcr_gym.calibration.drive`). Quasi-static, frictionless, no gravity.

    Args:
        data: the measurements (displacements or tensions).
        base: the nominal robot; ``drive``: its nominal tendon drive (needed for displacements).
        slack: False: the linear drive law (no slack), an ablation.
        stiffness_scale: multiplies every k (e.g. 1e3: the rigid-tendon limit).
    """

    name = "ccka"

    def __init__(
        self,
        data: Measurements,
        base: RobotParams,
        drive: TendonDrive | None = None,
        *,
        slack: bool = True,
        stiffness_scale: float = 1.0,
    ) -> None:
        if data.displacements is not None and drive is None:
            raise ValueError(
                "displacement data need the robot's tendon drive (stiffness, pretension): give "
                "a params YAML with calibration.tendons (docs/calibration.md) or a robot that "
                "carries tendon_stiffness/tendon_pretension"
            )
        self.data = data
        self.base = base
        self.drive = drive
        self.slack = slack
        self.stiffness_scale = float(stiffness_scale)

    def backend_kwargs(self, values: dict[str, float]) -> dict[str, Any]:
        return {}

    def batch(self, batch: list[dict[str, float]]) -> tuple[np.ndarray, np.ndarray]:
        """Tips and tangents (B, M, 3) for B value sets in one batched solve."""
        geom = drive_geometry(
            self.base, self.drive, batch, slack=self.slack, stiffness_scale=self.stiffness_scale
        )
        if self.data.displacements is not None:
            curvature = self._drive_curvature(geom, batch)
        else:
            g, _ = geom.coupling()
            u = np.einsum("bcn,mc->bmn", g, self.data.tensions) / geom.ei[:, None, None]
            curvature = u.reshape(len(batch), len(self.data), -1, 2)
        return forward_tips(geom, curvature)

    def _drive_curvature(self, geom: Any, batch: list[dict[str, float]]) -> np.ndarray:
        """Section curvatures (B, M, S, 2) of the B robots under the rows' commands, each
        robot's through its drives' backlash (``drive_backlash``, ``TendonDrive.backlash``;
        :func:`cdcr_gym.calibration.backlash.play`) and softening (``drive_softening``,
        ``TendonDrive.softening``; :func:`cdcr_gym.model.drive_softening.soften`): the robots
        that share both are solved together."""
        d = self.data.displacements
        assert d is not None and self.drive is not None
        drives = [
            (
                float(v.get("drive_backlash", self.drive.backlash)),
                float(v.get("drive_softening", self.drive.softening)),
            )
            for v in batch
        ]
        if not any(w > 0.0 or rate > 0.0 for w, rate in drives):
            return solve_drive(geom, d).curvature
        groups: dict[tuple[float, float], list[int]] = {}
        for b, key in enumerate(drives):
            groups.setdefault(key, []).append(b)
        out: np.ndarray | None = None
        for (w, rate), idx in groups.items():
            sub = drive_geometry(
                self.base,
                self.drive,
                [batch[i] for i in idx],
                slack=self.slack,
                stiffness_scale=self.stiffness_scale,
            )
            u = solve_drive(sub, soften(play(d, w), rate)).curvature
            if out is None:
                out = np.empty((len(batch), *u.shape[1:]))
            out[idx] = u
        assert out is not None
        return out

    def __call__(self, values: dict[str, float]) -> Prediction:
        tip, direction = self.batch([values])
        return Prediction(tip[0], direction[0])
