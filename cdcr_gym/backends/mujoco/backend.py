"""The MuJoCo backend: N robots as MJCF chains with one spatial tendon per cable.

The model (``mjcf``) is data; MuJoCo integrates it. Python touches the simulation once per
control step per robot (``mj_step`` with ``nstep`` physics steps, or one ``mujoco.rollout`` call
for all N robots), never per physics step — except with cable friction (μ > 0), whose capstan
segment tensions depend on the current wrap angles and are set before every physics step.

Tendon displacements (:meth:`MuJoCoBackend.apply_displacements`, SPEC §8) are native: the
first such command rebuilds the model with one ``general`` actuator per cable tendon whose force
is −clip(T0 + k·(d − (L0 − L)), 0, T_max) (``mjcf``: ``ctrl`` = d, the clamp is slack and
saturation), so MuJoCo evaluates the compliant law at every physics step from the tendon's
current length L. The drive's stiffness k·JᵀJ is explicit in MuJoCo's step (its stiffest modes
reach 4 000–56 000 rad/s: an explicit step would need h < 0.04–0.5 ms); to keep a stiff tendon
stable at the default timestep each cable tendon gets the damping γ·k with γ = the physics
timestep h (its ``damping``), and the model the ``implicitfast`` integrator, which (unlike
``Euler``) treats tendon damping implicitly: a stiff drive mode then contracts by about
1 − h/γ = 0 per step, whatever k (checked at the rebuild:
:meth:`MuJoCoBackend.drive_stability`). The damping is a passive force of the tendon, not of the
clamped actuator (gating it by the clamp makes the step chatter and diverge): a slack tendon is
viscous while the robot moves and carries exactly 0 N at rest. Measured on a step command that
pulls one tendon and releases another (gravity off, settling to 0.1 mm): paper robot 0.72 s at
its k = 2·10⁴ N/m, 2.8 s at k = 10⁵ N/m; ftdcr_v4 0.62 s at its k, 4.8 s at 10⁵ (pybullet,
whose drives are implicit without damping: 0.3–0.5 s in every case). Tension commands release the drives (``ctrl`` far
below the slack point, force exactly 0, damping off).

Frames: MuJoCo's world frame is the base frame R0 (backbone along +z); a turned base
(``base_orientation``) turns gravity into R0 instead of turning the robot, so every reading is
already in R0.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import (
    Backend,
    DriveState,
    Readings,
    SimulationDivergedError,
)
from cdcr_gym.backends.mujoco import friction as mj_friction
from cdcr_gym.backends.mujoco.backbone_friction import BackboneFriction
from cdcr_gym.backends.mujoco.damping import tune_damping
from cdcr_gym.backends.mujoco.drives import RELEASED, TendonDrives
from cdcr_gym.backends.mujoco.friction import CapstanFriction
from cdcr_gym.backends.mujoco.limits import StabilityLimits
from cdcr_gym.backends.mujoco.mjcf import JOINTS, MJCFModel, build_mjcf
from cdcr_gym.backends.mujoco.obstacles import ObstacleScene
from cdcr_gym.backends.mujoco.statics import StaticSolve
from cdcr_gym.model.discrete import (
    ROUTINGS,
    DiscreteBackbone,
    bending_modes,
    check_span_buckling,
    quat_to_matrix,
)
from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams
from cdcr_gym.model.statics import check_tip_payload

__all__ = ["MuJoCoBackend", "SimulationDivergedError", "INTEGRATORS"]

#: MuJoCo's warning of a non-finite acceleration (it then resets the data silently).
_BADQACC = 5  # mujoco.mjtWarning.mjWARN_BADQACC (a test checks the value)
#: Impedance (dmin, dmax, width m, midpoint, power) of the robot–sphere contacts (solid
#: spheres): MuJoCo's default (0.9, 0.95, …) lets 5–10 % of the robot's drive through a contact
#: (a cable at max_tension rests ~2 cm inside a sphere); 0.99–0.999 keeps it under ~1 mm.
CONTACT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: Most link bodies in one chain: MuJoCo's XML parser nests elements at most 500 deep (the
#: chain's bodies are nested, 4 levels above them).
MAX_LINKS = 495
#: MuJoCo integrators accepted by ``integrator``.
INTEGRATORS = ("Euler", "implicitfast", "implicit", "RK4")


def _mujoco() -> Any:
    import mujoco

    return mujoco


class MuJoCoBackend(
    ObstacleScene,
    TendonDrives,
    CapstanFriction,
    BackboneFriction,
    StabilityLimits,
    StaticSolve,
    Backend,
):
    """``num_robots`` CDCRs simulated by MuJoCo (see the module docstring and ``mjcf``).

    Args:
        params: the robot (:class:`~cdcr_gym.params.RobotParams`; default: the paper's), any
            number of sections. Rejected (``ValueError``) if its disk spans buckle with every
            cable at ``max_tension`` (``cdcr_gym.model.discrete.check_span_buckling``).
        num_robots: robots N stepped together (default 1, >= 1); one ``MjModel``, N ``MjData``.
        gravity: ``True`` (default) applies −9.81 m/s² along −Z_world; ``False`` none.
        links_per_span: rigid links per disk span, m >= 1 (default 1), at most
            ``MAX_LINKS // n_disks`` (MuJoCo's XML nesting limit: 55 for the paper robot).
        joint: (default ``"ball"``) a spherical joint, rotation-vector stiffness EI/Δ in every
            direction (also in twist, where the rod has GJ/Δ ≈ EI/(1.3Δ)), so that bending in
            any plane adds no spurious twist; or ``"cardan"``, bullet's two hinges Rx(a)·Ry(b)
            without a twist coordinate, whose composition twists by ≈ a·b/2 per joint when the
            bend is out of the x and y planes (1–2.6 % of ℓ at one link per span).
        routing: (default ``"corrected"``) cable via-sites ∓Δ/(3m) from every disk along its
            link, which cancels the discretisation's moment-arm excess at every joint (``mjcf``);
            or ``"disk"``, straight from pinhole to pinhole (bullet's model).
        control_timestep: simulated time (s) of one :meth:`apply_tensions` (default 0.02 s).
        physics_timestep: MuJoCo's timestep h (s), must divide ``control_timestep`` (default
            0.02 s: one physics step per control step). Stable because the damping D = β·K is
            stiffness-proportional and MuJoCo's Euler integrator treats it implicitly: long
            random-tension runs stay stable up to h = 0.1 s at ζ = 0.7 and 0.04 s at ζ = 0.3
            (``docs/mujoco_backend.md``). h changes the transient, never the settled state.
            Refused (``ValueError``) beyond :meth:`stable_timestep` (h <= β·min(1, 1/2 +
            β·ω₁/2) for the β that delivers ζ: 0.15 s at the default ζ = 0.7); a low
            ``damping_ratio`` needs a short step (``damping.py``).
        base_orientation: unit quaternion (x, y, z, w) of R0 in the world (default
            ``(0.0, 0.0, 0.0, 1.0)``: upright).
        tip_payload: point mass (kg, >= 0) at the tip disk centre (default 0.0). Rejected
            (``ValueError``) under gravity if the robot cannot hold it at the extreme shapes
            (``cdcr_gym.model.statics.check_tip_payload``, the check bullet makes).
        damping_ratio: damping ratio ζ > 0 of the first bending mode (default 0.7), as
            measured from the decay of a released tip: D = β·K with β ≈ 2ζ/ω₁, corrected for
            gravity and for the damping MuJoCo's step removes (``damping.py``). Refused
            (``ValueError``) below the minimum the timestep delivers stably (0.24 at 20 ms).
        friction_coefficient: cable–disk capstan μ in [0, 1] (default 0.0: frictionless, the
            plain MuJoCo path, bit-identical to a model without friction). μ > 0: every cable
            segment carries the capstan tension of ``cdcr_gym.model.friction`` (as on bullet),
            set before every physics step with the slip state implicit in the step
            (``backends/mujoco/friction.py``).
        friction_slip_length: slip length x_s of the slip law (default 1e-4 m, > 0).
        backbone_friction: Coulomb moment M_f (N·m, ≥ 0) against the bending of every joint
            (default 0.0; ``backbone_friction.py``).
        integrator: MuJoCo integrator (default ``"Euler"``: semi-implicit, damping implicit).
            Displacement commands switch ``"Euler"`` to ``"implicitfast"`` (module docstring);
            ``"RK4"`` cannot take them.
        threads: (default ``None``) the N robots are stepped one after the other in the
            calling thread, one MuJoCo call sequence per robot and control step; an integer k:
            by ``mujoco.rollout`` in k persistent threads that release the GIL (worth it when
            cores are free; measured in ``docs/mujoco_backend.md``).
        solid_obstacles: (default ``False``) whether the spheres placed by
            :meth:`set_obstacles` push the robot back (MuJoCo contacts as constraints); with
            ``False`` they are detected (:attr:`obstacle_clearance`) but exert no force.
            Needs ``integrator="Euler"``. A contact acts from the step after the robot touches
            a sphere: a robot moving fast (up to ~0.1 m per 0.02 s step under bang-bang
            tensions) can sink a few centimetres into it within one step, and is then pushed
            out over the next steps (time constant 2h); a robot held against a sphere rests
            within ~1 mm of its surface (``CONTACT_SOLIMP``).
        gate_damping: (default ``False``) the displacement drives' damping on the (nearly)
            taut tendons only (``TendonDrives.gate_damping``), as the calibration's replays
            use it; a fitted ``params.yaml`` of displacement data records it.

    Raises:
        ValueError: naming the argument and the value, for any invalid argument.
    """

    supports_length_control = False
    supports_displacement_control = True
    supports_obstacles = True
    randomizable = frozenset(
        {"youngs_modulus", "friction_coefficient", "gravity", "tip_payload", "backbone_friction"}
    )

    def __init__(
        self,
        params: RobotParams = RobotParams(),  # noqa: B008 (frozen, immutable)
        *,
        num_robots: int = 1,
        gravity: bool = True,
        links_per_span: int = 1,
        joint: str = "ball",
        routing: str = "corrected",
        control_timestep: float = 0.02,
        physics_timestep: float = 0.02,
        base_orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        tip_payload: float = 0.0,
        damping_ratio: float = 0.7,
        friction_coefficient: float = 0.0,
        friction_slip_length: float = 1e-4,
        backbone_friction: float = 0.0,
        integrator: str = "Euler",
        threads: int | None = None,
        solid_obstacles: bool = False,
        gate_damping: bool = False,
    ) -> None:
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        self.params = params
        self.num_robots = validation.integer(num_robots, "num_robots", 1)
        self.gravity = validation.flag(gravity, "gravity")
        self.links_per_span = validation.integer(links_per_span, "links_per_span", 1)
        self.joint = validation.choice(joint, "joint", JOINTS)
        self.routing = validation.choice(routing, "routing", ROUTINGS)
        self.control_timestep = validation.positive(control_timestep, "control_timestep")
        self.physics_timestep = validation.positive(physics_timestep, "physics_timestep")
        ratio = self.control_timestep / self.physics_timestep
        n_sub = round(ratio)
        if n_sub < 1 or abs(ratio - n_sub) > 1e-9 * max(1.0, ratio):
            raise ValueError(
                f"physics_timestep ({physics_timestep!r} s) must divide control_timestep "
                f"({control_timestep!r} s) into a whole number of steps"
            )
        self.n_substeps = int(n_sub)
        quat = validation.real_array(base_orientation, "base_orientation")
        if quat.shape != (4,) or abs(np.linalg.norm(quat) - 1.0) > 1e-6:
            raise ValueError(
                "base_orientation must be a finite unit quaternion (x, y, z, w) with norm 1 "
                f"(±1e-6), got {base_orientation!r}"
            )
        self.base_orientation = tuple(float(v) for v in quat / np.linalg.norm(quat))
        self.tip_payload = validation.positive(tip_payload, "tip_payload", allow_zero=True)
        self.damping_ratio = validation.positive(damping_ratio, "damping_ratio")
        self.friction_coefficient = validation.positive(
            friction_coefficient, "friction_coefficient", 1.0, allow_zero=True
        )
        self.friction_slip_length = validation.positive(
            friction_slip_length, "friction_slip_length"
        )
        self.integrator = validation.choice(integrator, "integrator", INTEGRATORS)
        self._splittable = self.integrator != "RK4"
        if threads is not None:
            threads = validation.integer(threads, "threads", 1)
        self.threads = threads
        self.solid_obstacles = validation.flag(solid_obstacles, "solid_obstacles")
        self.gate_damping = validation.flag(gate_damping, "gate_damping")
        if self.solid_obstacles and self.integrator != "Euler":
            # the contacts' inertia is set for Euler's step (_set_contact_inertia); with the
            # implicit integrators a fast robot sinks into a sphere and is thrown out of it
            raise ValueError(
                f"solid_obstacles=True needs integrator='Euler', got integrator="
                f"{self.integrator!r} (its contacts are not stable with this robot's damping)"
            )
        self.n_obstacles = 0
        most = MAX_LINKS // params.n_disks
        if self.links_per_span > most:
            raise ValueError(
                f"links_per_span must be in [1, {most}] for this robot ({params.n_disks} disk "
                f"spans; MuJoCo nests at most {MAX_LINKS} link bodies), got {links_per_span!r}"
            )
        check_span_buckling(params, self.links_per_span)
        self._base_rot = quat_to_matrix(np.asarray(self.base_orientation))
        #: Gravity (m/s²) in R0, the model's world frame.
        self.gravity_in_base = self._base_rot.T @ np.array([0.0, 0.0, -STANDARD_GRAVITY])
        self._mj = _mujoco()
        self._closed = False
        self._rollout: Any = None
        #: Whether the model has the displacement drives (built on the first displacement).
        self._drives = False
        self._driving = False  # whether the drives hold the last command (else released)
        self._displacements = np.zeros((self.num_robots, params.n_cables))
        self._drive_state: DriveState | None = None
        self._build(segment_tendons=self.friction_coefficient > 0.0)
        self._check_timestep(self.model, "")
        self._init_backbone_friction(
            validation.positive(backbone_friction, "backbone_friction", allow_zero=True)
        )
        # refuse, by name, a payload the robot cannot hold at the extreme shapes (goals and
        # random starts are drawn from them), as bullet does, instead of failing every reset
        check_tip_payload(
            self.tip_payload,
            params,
            self.gravity,
            # the plain iteration only: a payload it accepts, every reset handles
            lambda t: self._solve_static(self.model, self._scratch, t, relaxations=(1.0,)),
        )
        self._report_anchors = self.friction_coefficient > 0.0
        self._rough = self.friction_coefficient > 0.0  # any robot with μ > 0
        #: Per-robot friction coefficient μ (N,) and slip state s (N, C).
        self._mu = np.full(self.num_robots, self.friction_coefficient)
        self.slip = np.zeros((self.num_robots, params.n_cables))
        self.time = np.zeros(self.num_robots)
        self.reset(np.zeros((self.num_robots, params.n_cables)))

    # -- model ----------------------------------------------------------------------------------
    def _build(self, segment_tendons: bool, obstacles: int = 0) -> None:
        """Build the MJCF model, the N data and the index arrays (also after a change that
        needs new tendons, e.g. friction switched on by randomisation)."""
        mj = self._mj
        p = self.params
        self.mjcf: MJCFModel = build_mjcf(
            p,
            links_per_span=self.links_per_span,
            joint=self.joint,
            routing=self.routing,
            gravity=self.gravity_in_base if self.gravity else (0.0, 0.0, 0.0),
            tip_payload=self.tip_payload,
            timestep=self.physics_timestep,
            integrator="implicitfast"
            if self._drives and self.integrator == "Euler"
            else self.integrator,
            segment_tendons=segment_tendons,
            obstacles=obstacles,
            solid_obstacles=self.solid_obstacles,
            drives=self._drives,
        )
        self.n_obstacles = obstacles
        model = mj.MjModel.from_xml_string(self.mjcf.xml)
        self.n_links = self.mjcf.n_links
        self.n_dof = model.nv
        self._stiffness = np.array(model.jnt_stiffness[model.dof_jntid])  # (nv,) K per dof
        data = mj.MjData(model)
        mj.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mj.mj_fullM(model, data, mass)
        #: ω₁ and ω_max (rad/s) of the straight chain without gravity.
        self.first_mode_frequency, self.highest_mode_frequency = bending_modes(
            mass, self._stiffness
        )
        self._scratch = data
        #: β (s), D = β·K: the first mode as stepped has ``damping_ratio`` (``damping.py``).
        self.damping_time = tune_damping(self, model)
        self._contacts_active = obstacles > 0 and self.solid_obstacles
        if self._contacts_active:
            model.geom_solimp[:] = CONTACT_SOLIMP
        self._set_contact_inertia(model)
        self.model = model
        bare = DiscreteBackbone(p, self.links_per_span)
        self._bare_tip = (
            float(bare.link_masses[-1]),
            float(bare.link_com_offsets[-1]),
            tuple(bare.link_inertias[-1]),
        )
        self._nominal_stiffness = model.jnt_stiffness.copy()
        self._models = [model] * self.num_robots
        self._datas = [mj.MjData(model) for _ in range(self.num_robots)]
        self._scratch = mj.MjData(model)
        name = mj.mj_name2id
        site, tendon = mj.mjtObj.mjOBJ_SITE, mj.mjtObj.mjOBJ_TENDON
        self._station_ids = np.array([name(model, site, s) for s in self.mjcf.station_sites])
        self._tip_id = int(self._station_ids[-1])
        self._tip_body = int(model.site_bodyid[self._tip_id])
        geom = mj.mjtObj.mjOBJ_GEOM
        self._sphere_geoms = [name(model, geom, f"obstacle{k}") for k in range(obstacles)]
        self._robot_geoms = np.flatnonzero(model.geom_contype == 1).tolist()
        self._disk_site_ids = self._station_ids[np.asarray(self.mjcf.disk_links) - 1]
        self._pin_ids = np.array(
            [[name(model, site, s) for s in row] for row in self.mjcf.pinhole_sites]
        )
        c = p.n_cables
        #: L_i (C,) m and π r_i m_i (C,) m: no shape changes cable i's length by more.
        self._run_lengths = np.asarray(p.cable_run_lengths, dtype=float)
        self._length_reach = (
            math.pi * np.asarray(p.cable_radii) * (np.asarray(p.cable_section) + 1) * (1 + 1e-9)
        )
        self._cable_ids = np.array([name(model, tendon, f"cable{i}") for i in range(c)])
        self._n_pull = c
        n_seg = sum(n is not None for row in self.mjcf.segment_tendons for n in row)
        #: The displacement drives' ctrl entries (empty without drives).
        self._drive_slice = slice(c + n_seg, c + n_seg + (c if self._drives else 0))
        scratch = self._scratch
        mj.mj_resetData(model, scratch)
        mj.mj_kinematics(model, scratch)
        mj.mj_tendon(model, scratch)
        #: L0 (C,) m, the cables' tendon lengths at the straight pose.
        self._straight = np.array(scratch.ten_length[self._cable_ids])
        #: k (C,) N/m, T0 (C,) N and max_tension N of the drives.
        self._drive_constants = (
            np.asarray(p.cable_stiffness, dtype=np.float64),
            np.asarray(p.cable_pretension, dtype=np.float64),
            self.drive_max_tension,
        )
        #: c (N,) m/N, each robot's compliant base (``RobotParams.base_compliance``).
        self._base_compliance = np.full(self.num_robots, float(p.base_compliance))
        if self._drives:
            k = np.asarray(p.cable_stiffness)
            model.actuator_biasprm[self._drive_slice, 0] = k * self._straight - np.asarray(
                p.cable_pretension
            )
            model.actuator_forcerange[self._drive_slice, 0] = -self.drive_max_tension
        chain = self.mjcf.chain
        self.routed = chain.routed  # (n_disks, C)
        self._last_span = self.routed.sum(axis=0) - 1
        # the friction actuators follow the cables' pull actuators, cable-major (``mjcf``)
        self._segment_order = [
            (k, i)
            for i in range(c)
            for k in range(len(self.mjcf.segment_tendons))
            if self.mjcf.segment_tendons[k][i] is not None
        ]
        self._has_segments = bool(self._segment_order)
        self._segment_ids = np.array(
            [
                [-1 if n is None else name(model, tendon, n) for n in row]
                for row in self.mjcf.segment_tendons
            ]
        ).reshape(len(self.mjcf.segment_tendons), c)
        self._jac_index = (  # the cables' and the routed segments' rows of ten_J (friction)
            mj_friction.jacobian_index(model, self._cable_ids),
            mj_friction.jacobian_index(model, self._segment_ids[self._segment_ids >= 0]),
        )
        if self._rollout is not None:  # its thread data belong to the previous model
            self._rollout.close()
            self._rollout = None
        self._tensions = np.zeros((self.num_robots, c))
        self._tip = np.zeros((self.num_robots, 3))
        self._direction = np.zeros((self.num_robots, 3))
        self._lengths = np.zeros((self.num_robots, c))
        self._nstate = mj.mj_stateSize(model, mj.mjtState.mjSTATE_FULLPHYSICS)
        self._make_views()

    def _own_model(self, i: int) -> Any:
        """Robot i's own MjModel (a copy of the shared one, made on its first change)."""
        if self._models[i] is self.model:
            self._models[i] = copy.copy(self.model)
        return self._models[i]

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this MuJoCoBackend is closed")

    def _check_tensions(
        self, tensions: Any, rows: int | None = None, limit: float | None = None
    ) -> np.ndarray:
        """``tensions`` as (M, C) N in [0, ``limit``] (None: ``params.max_tension``)."""
        c = self.params.n_cables
        limit = self.params.max_tension if limit is None else limit
        t = validation.real_array(tensions, "tensions")
        if t.ndim == 1:
            t = t[None]
        if t.ndim != 2 or t.shape[1] != c or (rows is not None and t.shape[0] != rows):
            want = f"({rows if rows is not None else 'M'}, {c})"
            raise ValueError(f"tensions must have shape {want} (N, one per cable), got {t.shape}")
        if t.min() < 0.0 or t.max() > limit:
            raise ValueError(f"tensions must be in [0, max_tension={limit}] N, got {tensions!r}")
        return np.array(t)

    def _fast_tensions(self, tensions: Any) -> np.ndarray:
        """:meth:`_check_tensions` of (N, C) tensions, cheap for a float array (every step;
        a few values are checked as Python floats, cheaper than numpy reductions)."""
        if type(tensions) is np.ndarray and tensions.shape == self._tensions.shape:
            t = tensions.astype(np.float64)  # a copy
            high = self.params.max_tension
            if t.size <= 16:
                if all(0.0 <= x <= high for x in t.ravel().tolist()):  # NaN fails
                    return t
            elif 0.0 <= t.min() and t.max() <= high:
                return t
        return self._check_tensions(tensions, self.num_robots)

    # -- Backend API ----------------------------------------------------------------------------
    def reset(self, tensions: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Rest every robot of ``mask`` (all if None) in its static equilibrium under its row of
        ``tensions`` (N, C) N; time 0, neutral friction slip. Deterministic. Placed spheres
        stay; the static solve ignores them (the unobstructed equilibrium)."""
        self._check_open()
        n = self.num_robots
        t = self._check_tensions(tensions, n, limit=self.reset_max_tension)
        rows = range(n) if mask is None else np.flatnonzero(np.asarray(mask).reshape(n)).tolist()
        for i in rows:
            data, model = self._datas[i], self._models[i]
            spheres = data.mocap_pos.copy()  # the scene stays (set_obstacles)
            self._mj.mj_resetData(model, data)
            data.mocap_pos[:] = spheres
            if not self._solve_static_fast(model, data, t[i]):
                raise self._diverged("no static equilibrium found", data, t[i], 0.0)
            data.time = 0.0
            self._tensions[i] = t[i]
            self.slip[i] = 0.0
            self._backbone_slip[i] = 0.0
            self.time[i] = 0.0
            self._sense(i)

    def apply_tensions(self, tensions: np.ndarray) -> None:
        """Hold ``tensions`` (N, C) N for one control step (``n_substeps`` MuJoCo steps).

        Raises:
            SimulationDivergedError: if a state becomes non-finite, a joint bends beyond 90° or
                turns faster than 1000 rad/s, or MuJoCo reports a bad acceleration.
        """
        self._check_open()
        t = self._fast_tensions(tensions)
        self._tensions = t
        n_pull = self._n_pull
        self.time += self.control_timestep
        if self._drives:
            self._release_drives()
        if self._rough:
            self._step_with_friction(t)
            for i in range(self.num_robots):
                self._check_state(i)
        elif self.threads is None or self._backbone_rough():
            advance, check, sense, n_sub = (
                self._advance,
                self._check_state,
                self._sense,
                self.n_substeps,
            )
            views = self._views
            for i, data in enumerate(self._datas):
                views[i][6][:n_pull] = t[i]
                advance(self._models[i], data, n_sub, i)
                check(i)
                sense(i)
        else:
            for data, row in zip(self._datas, t):
                data.ctrl[:n_pull] = row
            self._rollout_step()
            for i in range(self.num_robots):
                self._check_state(i)
                self._sense(i)

    def _advance(self, model: Any, data: Any, n_steps: int, robot: int | None = None) -> None:
        """``n_steps`` MuJoCo steps of one robot, leaving ``data`` with the position and
        velocity stages (``mj_step1``) of the new state computed: what the readings and the next
        step's ``mj_step2`` use, so that no stage is computed twice. (``mj_step`` computes them
        for the state it starts from; ``mj_step1`` + ``mj_step2`` = ``mj_step``.) RK4 cannot be
        split: full steps, then ``mj_step1``. ``robot``: its index, for its backbone friction
        (``backbone_friction.py``)."""
        if robot is not None and self._backbone_torque[robot] > 0.0:
            self._advance_with_backbone_friction(model, data, n_steps, robot)
            return
        mj = self._mj
        if self._splittable:
            mj.mj_step2(model, data)
            if n_steps > 1:
                mj.mj_step(model, data, n_steps - 1)
        else:
            mj.mj_step(model, data, n_steps)
        mj.mj_step1(model, data)

    def _rollout_step(self) -> None:
        """All N robots for ``n_substeps`` steps in one ``mujoco.rollout`` call (threads that
        release the GIL)."""
        mj = self._mj
        from mujoco import rollout

        if self._rollout is None:
            nthread = min(self.num_robots, self.threads or 1)
            self._rollout = rollout.Rollout(nthread=nthread)
            self._thread_datas = [mj.MjData(self.model) for _ in range(nthread)]
            self._state_buf = np.empty((self.num_robots, self._nstate))
            self._ctrl_buf = np.empty((self.num_robots, self.n_substeps, self.model.nu))
            self._out_buf = np.empty((self.num_robots, self.n_substeps, self._nstate))
            self._sensor_buf = np.empty((self.num_robots, self.n_substeps, self.model.nsensordata))
        spec = mj.mjtState.mjSTATE_FULLPHYSICS
        for i, data in enumerate(self._datas):
            mj.mj_getState(self._models[i], data, self._state_buf[i], spec)
            self._ctrl_buf[i] = data.ctrl
        warn = mj.mjtWarning.mjWARN_BADQACC
        for data in self._thread_datas:
            data.warning[warn].number = 0
        self._rollout.rollout(
            self._models,
            self._thread_datas,
            self._state_buf,
            self._ctrl_buf,
            skip_checks=True,
            nstep=self.n_substeps,
            state=self._out_buf,
            sensordata=self._sensor_buf,
        )
        if any(data.warning[warn].number > 0 for data in self._thread_datas):
            raise self._diverged(
                "the simulation diverged (MuJoCo: bad acceleration in a rollout)",
                self._thread_datas[0],
                self._tensions[0],
                float(self.time.max()),
            )
        final = self._out_buf[:, -1]
        for i, data in enumerate(self._datas):
            mj.mj_setState(self._models[i], data, final[i], spec)
            mj.mj_step1(self._models[i], data)

    # -- reading --------------------------------------------------------------------------------
    def _sense(self, i: int) -> None:
        """Robot i's tip, tip direction and cable lengths (tendon lengths) from its data, which
        holds the position stage of its current state (:meth:`_advance`)."""
        xpos, xmat, lengths = self._views[i][3:6]
        tid = self._tip_id
        self._tip[i] = xpos[tid]
        self._direction[i] = xmat[tid, 2::3]
        self._lengths[i] = lengths[self._cable_ids]

    def _make_views(self) -> None:
        """Per robot: numpy views of the ``MjData`` arrays read every step (a view stays valid
        for the data's life; taking one through the binding costs more than the read)."""
        warn = _BADQACC
        self._views = [
            (d.qpos, d.qvel, d.warning[warn], d.site_xpos, d.site_xmat, d.ten_length, d.ctrl)
            for d in self._datas
        ]

    def read(self) -> Readings:
        self._check_open()
        anchors = self.anchor_tensions if self._report_anchors else None
        return Readings(
            self._tip.copy(),
            self._direction.copy(),
            self._lengths.copy(),
            self._tensions.copy(),
            anchors,
        )

    def backbone_points(self, index: int = 0) -> np.ndarray:
        """Backbone polyline (2n+1, 3) m in R0: base, then per link its joint and its station
        (every disk centre), tip last."""
        self._check_open()
        data = self._datas[index]
        pts = np.zeros((2 * self.n_links + 1, 3))
        pts[1::2] = data.xpos[1 + 1 : 1 + 1 + self.n_links]  # link bodies follow world, base
        pts[2::2] = data.site_xpos[self._station_ids]
        return pts

    def disk_frames(self, index: int = 0) -> tuple[np.ndarray, np.ndarray]:
        self._check_open()
        data = self._datas[index]
        ids = self._disk_site_ids
        centres = np.zeros((ids.size + 1, 3))
        centres[1:] = data.site_xpos[ids]
        rots = np.empty((ids.size + 1, 3, 3))
        rots[0] = np.eye(3)
        rots[1:] = data.site_xmat[ids].reshape(-1, 3, 3)
        return centres, rots

    @property
    def tensions(self) -> np.ndarray:
        """Cable tensions (N, C) N currently held."""
        return self._tensions.copy()

    def set_randomized(self, index: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Give robots ``index`` their drawn ``youngs_modulus`` (joint stiffness and damping,
        ζ kept), ``friction_coefficient``, ``gravity`` (1.0 on, 0.0 off) and ``tip_payload``
        (the tip link's mass and inertia). Each robot with a changed parameter gets its own
        copy of the MjModel; the rest are ignored (reported only)."""
        idx = np.asarray(index).reshape(-1).tolist()
        if "friction_coefficient" in values:
            mu = validation.real_array(values["friction_coefficient"], "friction_coefficient")
            if np.any(mu < 0.0) or np.any(mu > 1.0):
                raise ValueError(f"friction_coefficient must be in [0, 1], got {mu!r}")
            if np.any(mu > 0.0) and not self._has_segments:
                self._rebuild(True, self.n_obstacles)
            self._mu[idx] = mu
            self._rough = bool(np.any(self._mu > 0.0))
            self._report_anchors = True
        for j, i in enumerate(idx):
            if "gravity" in values:
                on = bool(values["gravity"][j] > 0.5)
                self._own_model(i).opt.gravity[:] = self.gravity_in_base if on else 0.0
            if values.keys() & {"youngs_modulus", "tip_payload", "gravity"}:
                model = self._own_model(i)
                if "youngs_modulus" in values:
                    ratio = float(values["youngs_modulus"][j]) / self.params.youngs_modulus
                    model.jnt_stiffness[:] = self._nominal_stiffness * ratio
                if "tip_payload" in values:
                    self._set_payload(model, float(values["tip_payload"][j]))
                self._tune_damping(model)
        if "backbone_friction" in values:  # after the stiffness: its stability check uses it
            self.set_backbone_friction(idx, values["backbone_friction"])

    def _tune_damping(self, model: Any) -> None:
        """D = β·K with the β that gives ``model``'s own first bending mode (its stiffness,
        masses and gravity) the damping ratio ζ as stepped (``damping.py``)."""
        tune_damping(self, model)
        self._set_contact_inertia(model)

    def _set_contact_inertia(self, model: Any) -> None:
        """With solid spheres (contacts in MuJoCo's constraint solver) and the Euler integrator:
        the damping's implicit term h·D moved from Euler's damping step into the mass matrix
        (``dof_armature`` = h·D, Euler's implicit damping off). The step is the same,
        (M + h·D)·Δq̇ = h·f, but the constraint solver then sees the inertia the step has: the
        joints' damping is ~10³ times M/h, and a solver working with M alone computes contact
        forces for a robot 10³ times lighter than the step moves, which let a fast robot sink
        centimetres into a sphere and then threw it out at tens of rad/s. No change without
        solid spheres or with another integrator."""
        if not (self._contacts_active and self.integrator == "Euler"):
            return
        model.dof_armature[:] = model.opt.timestep * model.dof_damping
        model.opt.disableflags |= self._mj.mjtDisableBit.mjDSBL_EULERDAMP

    def _set_payload(self, model: Any, payload: float) -> None:
        """The tip link's mass, COM and inertia with ``payload`` kg at the tip disk centre."""
        body = self._tip_body
        bare = self._bare_tip  # (mass, COM offset, inertias) of the tip link without payload
        z_tip = 0.5 * float(self.mjcf.chain.segment_lengths[-1])
        mass = bare[0] + payload
        com = (bare[0] * bare[1] + payload * z_tip) / mass
        inertia = np.array(bare[2], dtype=float)
        inertia[:2] += bare[0] * (bare[1] - com) ** 2 + payload * (z_tip - com) ** 2
        model.body_mass[body] = mass
        model.body_ipos[body] = (0.0, 0.0, com)
        model.body_inertia[body] = inertia
        self._mj.mj_setConst(model, self._scratch)

    def _rebuild(self, segment_tendons: bool, obstacles: int) -> None:
        """A new model with friction segments and/or ``obstacles`` sphere geoms (more tendons or
        geoms, the same joints); every robot keeps its state (joint positions and rates,
        tensions, time), its randomised stiffness, damping, gravity and payload, and its
        placed spheres."""
        mj = self._mj
        old_shared, old_models, old_datas = self.model, self._models, self._datas
        old_spheres = self._sphere_geoms
        tensions = self._tensions.copy()
        self._build(segment_tendons=segment_tendons, obstacles=obstacles)
        self._tensions = tensions
        tip = self._tip_body  # the chain's bodies come first in both models
        for i, (old_model, old_data) in enumerate(zip(old_models, old_datas)):
            if old_model is not old_shared:  # randomised or with spheres: its own model
                model = self._own_model(i)
                model.jnt_stiffness[:] = old_model.jnt_stiffness
                model.dof_damping[:] = old_model.dof_damping
                self._set_contact_inertia(model)
                model.opt.gravity[:] = old_model.opt.gravity
                for field in ("body_mass", "body_ipos", "body_inertia"):
                    getattr(model, field)[tip] = getattr(old_model, field)[tip]
                # the constants derived from the masses (subtree masses, the inverse weights
                # that scale the contacts' regularisation), as _set_payload computes them
                mj.mj_setConst(model, self._scratch)
                for old_g, new_g in zip(old_spheres, self._sphere_geoms):
                    for field in ("geom_size", "geom_rbound", "geom_aabb"):
                        getattr(model, field)[new_g] = getattr(old_model, field)[old_g]
                    node = model.body_bvhadr[model.geom_bodyid[new_g]]
                    model.bvh_aabb[node] = old_model.bvh_aabb[
                        old_model.body_bvhadr[old_model.geom_bodyid[old_g]]
                    ]
            model = self._models[i]
            data = self._datas[i]
            data.qpos[:] = old_data.qpos
            data.qvel[:] = old_data.qvel
            data.ctrl[: self._n_pull] = 0.0 if self._driving else tensions[i]
            data.ctrl[self._drive_slice] = self._displacements[i] if self._driving else RELEASED
            data.time = old_data.time
            k = min(old_data.mocap_pos.shape[0], data.mocap_pos.shape[0])
            data.mocap_pos[:k] = old_data.mocap_pos[:k]
            mj.mj_forward(model, data)
            self._sense(i)
        if self._drives:
            self._set_drive_damping(self._driving)

    def close(self) -> None:
        """Release the MuJoCo data and the rollout threads. Safe to call more than once."""
        if self._closed:
            return
        self._closed = True
        if self._rollout is not None:
            self._rollout.close()
            self._rollout = None
        self._datas = []
        self._models = []

    # -- copies -------------------------------------------------------------------------------
    def __getstate__(self) -> dict:
        """Pickling and deep copies carry the whole simulation (``MjModel`` and ``MjData``
        pickle by value; unlike a pybullet client, nothing lives outside the process): a copy
        steps exactly like the original, independently of it. Not carried: the mujoco module,
        the rollout threads and the cached array views (rebuilt on unpickling)."""
        state = self.__dict__.copy()
        for key in ("_mj", "_rollout", "_thread_datas", "_views"):
            state.pop(key, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._mj = _mujoco()
        self._rollout = None
        self._make_views()
