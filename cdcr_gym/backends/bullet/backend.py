"""The pybullet backend: the backbone as a chain of rigid links with elastic 2-DOF joints.

The parts (derivations and measured numbers in ``docs/bullet_backend.md``):

``cdcr_gym.model.discrete``
    The discretised backbone as pure numpy, shared with the MuJoCo backend: links, Cardan
    joints half-way between the rod stations, masses, cable routing through the disks of n
    sections (pinhole to pinhole, or the corrected via-points: ``routing``), the cable loads as
    generalized forces τ = −Σ_i T_i ∂l_i/∂q, gravity loads, statics, and the span-buckling
    limit of the tensions.
``multibody``
    That chain as a pybullet multibody (the cap of :data:`MAX_JOINTS` joints per body).
``integrator``
    The physics step: backward-Euler joint springs and dampers around pybullet's step, cable
    and gravity loads explicit, and the divergence check.
``client``
    Connecting (headless or GUI, with a clear error where no display exists), the silent
    import, disconnecting, and why a backend is never copied.

This module holds :class:`BulletBackend`, which ties them together behind the
:class:`~cdcr_gym.backends.base.Backend` interface (N = 1 robot).

Frames
    The base frame R0 is the base disk centre with the backbone along +Z0 and β = 0 at +X0.
    ``base_orientation`` places R0 in the world (pybullet's frame, gravity −Z_world). Every
    position this backend returns (:attr:`tip`, :meth:`backbone_points`) is expressed in R0
    unless stated otherwise (:attr:`tip_world`, ``backbone_points(frame="world")``).

Tendon displacements (:meth:`BulletBackend.apply_displacements`, SPEC §8)
    The compliant drives' law T = clip(T0 + k·(d − (L0 − l(q))), 0, max_tension) is evaluated
    from the tendons' current lengths in the integrator, every physics step, with the drives'
    stiffness implicit (``ImplicitIntegrator.advance_displacements``): stable for stiff
    tendons at any physics timestep; a tendon slack at the end of a step carries exactly 0 N,
    a saturated one max_tension. Frictionless only (cable friction with displacement commands
    is refused).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import (
    MAX_JOINT_ANGLE,
    Backend,
    DriveState,
    Readings,
    SimulationDivergedError,
    diverged,
    drive_tensions,
)
from cdcr_gym.backends.bullet.client import Connection, copy_refused
from cdcr_gym.backends.bullet.damping import backend_damping_time, gravity_stiffness
from cdcr_gym.backends.bullet.integrator import ImplicitIntegrator
from cdcr_gym.backends.bullet.multibody import MAX_JOINTS, build_multibody
from cdcr_gym.backends.bullet.rendering import BulletRendering
from cdcr_gym.model.discrete import (
    ROUTINGS,
    ChainPose,
    DiscreteBackbone,
    bending_modes,
    check_span_buckling,
    quat_to_matrix,
)
from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams
from cdcr_gym.model.statics import check_tip_payload

__all__ = ["BulletBackend"]


class BulletBackend(BulletRendering, Backend):
    """The CDCR backbone simulated as a pybullet multibody (see the module docstring).

    Args:
        params: the robot (:class:`~cdcr_gym.params.RobotParams`; default: the paper's Table 1),
            any number of sections and of cables per section. Rejected (``ValueError``) if its
            disk spans buckle with every cable at ``max_tension``
            (:func:`~cdcr_gym.model.discrete.check_span_buckling`).
        gravity: ``True`` (default) applies −9.81 m/s² along −Z_world; ``False`` switches
            gravity off (the paper's simulation and the pure-moment statics have none).
        links_per_span: rigid links per disk span, m >= 1 (default 1): the chain has
            ``Σ n_disks·m`` links and twice as many revolute joints. Larger m converges to a
            continuous rod between the disks at a cost in speed (m = 4: ≈ 4.7× slower).
            Σ n_disks·m <= 60 (:data:`MAX_JOINTS`, one pybullet body).
        routing: ``"corrected"`` (default) routes every cable through two via-points ∓Δ/(3m)
            along each intermediate disk's link, which cancels the discretisation's excess
            moment arm (the default is within 0.5 % of ℓ of the converged Cosserat rod at one
            link per span, ``docs/bullet_backend.md``); ``"disk"`` runs it straight from
            pinhole to pinhole (span-mean moment-arm excess (1 + 2/m²) times the physical one,
            see ``cdcr_gym.model.discrete``; converges only with more ``links_per_span``).
        control_timestep: simulated time (s) that one :meth:`apply_tensions` advances
            (default 0.02 s, i.e. 50 Hz control).
        physics_timestep: pybullet step h (s), must divide ``control_timestep`` (default
            0.01 s: two physics steps per control step). The implicit spring–damper treatment
            is stable for any h up to ``control_timestep``; h only changes the transient
            (backward Euler adds numerical damping ≈ h·ω/2 to a mode of frequency ω), never
            the settled equilibrium.
        base_orientation: unit quaternion (x, y, z, w) of the base frame R0 in the world
            (default (0, 0, 0, 1): upright, backbone along +Z_world, against gravity). E.g.
            ``(0, sin 45°, 0, cos 45°)`` turns the backbone to +X_world (a horizontal
            cantilever). Returned positions stay in R0.
        tip_payload: point mass (kg, >= 0) at the tip disk centre (default 0.0).
        gui: open the pybullet GUI instead of a headless client (default ``False``); needs a
            display (else ``RuntimeError``). pybullet allows one GUI client per process.
        damping_ratio: damping ratio ζ > 0 of the first bending mode (default 0.7), as
            measured from the decay of a released tip; the joint damping is D = β·K with
            β ≈ 2ζ/ω₁, corrected for gravity and for the step's own damping (``damping.py``).
            Refused (``ValueError``) below that own damping (0.096 at 10 ms). Larger values settle the first mode without overshoot
            but slow the higher modes (rate ω₁/(2ζ)).
        friction_coefficient: cable–disk friction μ in [0, 1] (default 0.0: frictionless,
            bit-identical to the model without friction). With μ > 0 every cable carries the
            capstan tension profile along its segments (``integrator`` module docstring,
            ``cdcr_gym.model.friction``), and :meth:`read` reports the tension at each
            cable's anchor (``info["anchor_tensions"]``).
        friction_slip_length: sliding distance x_s (m, > 0; default 1e-4) over which friction
            builds up after the sliding direction reverses (the regularised stick–slip).

    Raises:
        ValueError: naming the argument and the value, for any invalid argument.
    """

    supports_length_control = False
    supports_displacement_control = True
    randomizable = frozenset({"youngs_modulus", "friction_coefficient", "gravity"})

    def __init__(
        self,
        params: RobotParams = RobotParams(),  # noqa: B008 (frozen, immutable)
        *,
        gravity: bool = True,
        links_per_span: int = 1,
        control_timestep: float = 0.02,
        physics_timestep: float = 0.01,
        base_orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        tip_payload: float = 0.0,
        gui: bool = False,
        damping_ratio: float = 0.7,
        friction_coefficient: float = 0.0,
        friction_slip_length: float = 1e-4,
        routing: str = "corrected",
    ) -> None:
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        self.params = params
        self.gravity = validation.flag(gravity, "gravity")
        self.gui = validation.flag(gui, "gui")
        self.links_per_span = validation.integer(links_per_span, "links_per_span", 1)
        self.routing = validation.choice(routing, "routing", ROUTINGS)
        self.control_timestep = validation.positive(control_timestep, "control_timestep", unit="s")
        self.physics_timestep = validation.positive(physics_timestep, "physics_timestep", unit="s")
        ratio = self.control_timestep / self.physics_timestep
        n_sub = round(ratio)
        if n_sub < 1 or abs(ratio - n_sub) > 1e-9 * max(1.0, ratio):
            raise ValueError(
                f"physics_timestep ({physics_timestep!r} s) must divide control_timestep "
                f"({control_timestep!r} s) into a whole number of steps"
            )
        self.n_substeps = int(n_sub)
        try:
            quat = np.asarray(base_orientation, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"base_orientation must be 4 numbers (x, y, z, w), got {base_orientation!r}"
            ) from None
        if (
            quat.shape != (4,)
            or not np.all(np.isfinite(quat))
            or abs(np.linalg.norm(quat) - 1.0) > 1e-6
        ):
            raise ValueError(
                "base_orientation must be a finite unit quaternion (x, y, z, w) with norm 1 "
                f"(±1e-6), got {base_orientation!r}"
            )
        self.base_orientation = tuple(float(v) for v in quat / np.linalg.norm(quat))
        self.tip_payload = validation.positive(
            tip_payload, "tip_payload", allow_zero=True, unit="kg"
        )
        self.damping_ratio = validation.positive(damping_ratio, "damping_ratio")
        self.friction_coefficient = validation.positive(
            friction_coefficient, "friction_coefficient", 1.0, allow_zero=True
        )
        self.friction_slip_length = validation.positive(
            friction_slip_length, "friction_slip_length", unit="m"
        )

        p = params
        n_links = sum(s.n_disks for s in p.sections) * self.links_per_span
        if n_links > MAX_JOINTS:
            disks = " + ".join(str(s.n_disks) for s in p.sections)
            raise ValueError(
                f"params: n_disks ({disks}) × links_per_span {self.links_per_span} = {n_links} "
                f"joints, but a pybullet multibody holds at most {MAX_JOINTS} (its state holds "
                "121 joint coordinates); use fewer disks or links per span "
                "(cdcr_gym.model.discrete.DiscreteBackbone evaluates longer chains' statics)"
            )
        check_span_buckling(p, self.links_per_span)
        self._base_rot = quat_to_matrix(np.asarray(self.base_orientation))
        #: The discretised backbone: geometry, masses, cable and gravity loads, statics.
        self.chain = DiscreteBackbone(
            p, self.links_per_span, self.tip_payload, self._base_rot, self.gravity, self.routing
        )
        self.n_links = self.chain.n_links  # links = 2-DOF joints
        self.n_dof = self.chain.n_dof  # revolute coordinates, 2 per joint
        #: Station spacing Δ_j per link (n_links,) m (h/m of the link's section).
        self.segment_lengths = self.chain.segment_lengths
        self._tensions = np.zeros(p.n_cables)
        self._pose: ChainPose | None = None
        self._points: tuple[np.ndarray, np.ndarray] | None = None
        # gravity in R0 coordinates, when it differs from the upright (0, 0, −g) (see integrator)
        g_base = self._base_rot.T @ np.array([0.0, 0.0, -STANDARD_GRAVITY])
        upright = np.allclose(g_base, (0.0, 0.0, -STANDARD_GRAVITY), rtol=0.0, atol=1e-12)
        gravity_in_base = None if (upright or not self.gravity) else tuple(g_base.tolist())
        self._tilted_gravity = None if upright else tuple(g_base.tolist())
        self._nominal_stiffness = self.chain.stiffness.copy()
        self._report_anchors = self.friction_coefficient > 0.0
        self._straight: np.ndarray | None = None  # L0 (C,) m of the drives, on first use
        self._drive_state: DriveState | None = None
        self.time = 0.0

        self._connection: Connection | None = Connection(self, self.gui)
        self._pb = pb = self._connection.pb
        self._client: int | None = self._connection.id
        try:
            bodies = build_multibody(
                pb,
                self._client,
                self.chain,
                base_orientation=self.base_orientation,
                physics_timestep=self.physics_timestep,
                gravity=self.gravity,
            )
            self._body, self._goal_body = bodies.body, bodies.goal_marker
            if self.gui:
                pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=self._client)
                target = self._base_rot @ np.array([0.0, 0.0, 0.4 * p.length])
                pb.resetDebugVisualizerCamera(
                    1.9 * p.length, 30.0, -20.0, target.tolist(), physicsClientId=self._client
                )
            mass0 = np.asarray(
                pb.calculateMassMatrix(self._body, [0.0] * self.n_dof, physicsClientId=self._client)
            )
            #: Angular frequency ω₁ (rad/s) of the first bending mode at the straight pose, and
            #: of the highest mode ω_max (what an explicit integrator would have to resolve).
            self.first_mode_frequency, self.highest_mode_frequency = bending_modes(
                mass0, self.chain.stiffness
            )
            self._mass0 = mass0
            self._gravity_stiffness = gravity_stiffness(self.chain)
            #: Stiffness-proportional damping time β ≈ 2ζ/ω₁ (s), D = β·K, that delivers ζ on
            #: the first mode as stepped, with gravity (``damping.py``).
            self.damping_time = backend_damping_time(self)
            self._integrator = ImplicitIntegrator(
                pb,
                self._client,
                self._body,
                self.chain,
                self.physics_timestep,
                self.damping_time,
                gravity_in_base,
                self.friction_coefficient,
                self.friction_slip_length,
            )
            self._joint_ids = self._integrator.joint_ids
            # refuse, by name, a payload the robot cannot hold at the extreme shapes (goals are
            # drawn from them), instead of a divergence at every reset
            check_tip_payload(
                self.tip_payload,
                p,
                self.gravity,
                lambda t: self.chain.static_equilibrium(
                    t, self._integrator.gravity_bias, max_angle=MAX_JOINT_ANGLE
                )[1],
            )
            self.reset(np.zeros(p.n_cables))
        except BaseException:
            self.close()
            raise

    # ---------------------------------------------------------------- state access

    def _check_open(self) -> None:
        if self._client is None:
            raise RuntimeError("this BulletBackend is closed")

    def _state(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles q (2n,) rad and rates q̇ (2n,) rad/s (cached until a step)."""
        return self._integrator.state()

    def _read(self) -> ChainPose:
        """World geometry of the current state (cached until the next step).

        The link frames come from the chain model's float64 forward kinematics, because
        pybullet's ``getLinkState`` returns positions rounded to single precision (~1e-8 m),
        too coarse for finite-difference checks; a test checks the two agree.
        """
        if self._pose is None:
            self._pose = self.chain.pose(self._state()[0])
        return self._pose

    def _read_points(self) -> tuple[np.ndarray, np.ndarray]:
        """World stations (n+1, 3) and pinholes (n_disks+1, C, 3), m, of the current state.

        What the tip and the sensed cable lengths need, without the joint axes and COMs of the
        full :meth:`_read` (same values, same bits). Cached until the next step, like the pose.
        """
        if self._points is None:
            if self._pose is not None:
                self._points = (self._pose.stations, self._pose.pinholes)
            else:
                self._points = self.chain.stations_and_pinholes(self._state()[0])
        return self._points

    def _invalidate(self) -> None:
        """Drop the cached geometry (after every change of the pybullet state)."""
        self._pose = self._points = None

    def _pybullet_link_frames(self) -> tuple[np.ndarray, np.ndarray]:
        """pybullet's own link-frame positions (2n, 3) and rotations (2n, 3, 3), world (for tests)."""
        self._check_open()
        ls = self._pb.getLinkStates(
            self._body, self._joint_ids, computeForwardKinematics=1, physicsClientId=self._client
        )
        frames = np.array([s[4] + s[5] for s in ls])
        return frames[:, :3], quat_to_matrix(frames[:, 3:])

    def _to_base(self, points_world: np.ndarray) -> np.ndarray:
        return points_world @ self._base_rot  # R0 = Rᵀ·world (base at the origin)

    def _set_state(self, q: np.ndarray, qd: np.ndarray) -> None:
        self._integrator.set_state(q, qd)
        self._invalidate()

    def _diverged(
        self, message: str, q: np.ndarray, qd: np.ndarray, t: np.ndarray
    ) -> SimulationDivergedError:
        return diverged(message, q, qd, t, self.time)

    # ---------------------------------------------------------------- Backend API

    def _check_tensions(self, tensions, limit: float | None = None) -> np.ndarray:
        """``tensions`` as (C,) N in [0, ``limit``] (None: ``params.max_tension``)."""
        c = self.params.n_cables
        limit = self.params.max_tension if limit is None else limit
        try:
            t = np.array(tensions, dtype=np.float64)  # a copy
        except (TypeError, ValueError):
            raise ValueError(
                f"tensions must be {c} real numbers (N), one per cable, got {tensions!r}"
            ) from None
        if t.shape != (c,):
            raise ValueError(
                f"tensions must have shape ({c},) (N, one per cable), got shape {t.shape}: "
                f"{tensions!r}"
            )
        lo, hi = t.min(), t.max()
        if not (0.0 <= lo and hi <= limit):  # also catches NaN
            raise ValueError(
                f"tensions must be finite and in [0, max_tension={limit}] N, got {tensions!r}"
            )
        return t

    def static_equilibrium(self, tensions: np.ndarray) -> np.ndarray:
        """Joint angles q (2n,) rad of the static equilibrium under ``tensions`` (C,) N.

        Solves K·q = τ_cable(q) − b(q, 0) (b from pybullet's inverse dynamics: gravity) by the
        fixed-point iteration q ← K⁻¹·(τ_cable(q) − b(q, 0)) from the straight pose, to
        max |Δq| < 1e-14 rad. It converges because the cable and gravity load stiffnesses are
        small against K (contraction factor ≈ 0.1–0.3 at the maximum tension); the limit is the
        stable equilibrium the dynamics settle to. Does not change the simulation state.

        Raises:
            SimulationDivergedError: if the iteration does not converge in 1000 steps (the
                cables' load stiffness beats the joints': robots whose spans buckle are
                rejected at construction, see ``chain.check_span_buckling``).
        """
        self._check_open()
        return self._static_q(self._check_tensions(tensions))

    def _static_q(self, t: np.ndarray) -> np.ndarray:
        """:meth:`static_equilibrium` of checked tensions (C,) N."""
        q, converged = self.chain.static_equilibrium(
            t, self._integrator.gravity_bias, max_angle=MAX_JOINT_ANGLE
        )
        if not converged:
            payload = (
                f" (with tip_payload={self.tip_payload!r} kg under gravity: a lighter payload "
                "may help)"
                if self.tip_payload > 0.0 and self.gravity
                else ""
            )
            raise self._diverged(
                "no static equilibrium found: the cables' destabilising load stiffness (which grows "
                "with the disk spacing, see cdcr_gym.model.discrete) exceeds the joint stiffness; "
                "use more disks, more links_per_span or lower tensions" + payload,
                q,
                np.zeros(self.n_dof),
                t,
            )
        return q

    def _reset_robot(self, tensions: np.ndarray) -> None:
        """Put the chain at rest in its static equilibrium under ``tensions`` (C,) N.

        Sets q = :meth:`static_equilibrium` (tensions) and q̇ = 0 and the simulated
        :attr:`time` to 0. The result depends only on ``tensions`` and the constructor
        arguments (the solver always starts from the straight pose), so the same call gives
        bit-identical state whatever happened before; :meth:`apply_tensions` with the same
        tensions then leaves the chain at rest.

        Raises:
            ValueError: if ``tensions`` is not C finite values in [0,
                :attr:`reset_max_tension`].
            SimulationDivergedError: if no equilibrium is found.
        """
        self._check_open()
        t = self._check_tensions(tensions, self.reset_max_tension)
        q = self._static_q(t)
        self._set_state(q, np.zeros(self.n_dof))
        self._tensions = t
        self.time = 0.0
        self._integrator.reset_friction()
        self._drive_state = None

    def _tick(self) -> None:
        self._pose = self._points = None
        self.time += self.physics_timestep

    def _hold_tensions(self, tensions: np.ndarray) -> None:
        """Hold ``tensions`` (C,) N for one control step (``n_substeps`` physics steps,
        :meth:`ImplicitIntegrator.advance`).

        Raises:
            ValueError: if ``tensions`` is not C finite values in [0, max_tension].
            SimulationDivergedError: if the state becomes non-finite, a joint bends beyond
                90° or turns faster than 1000 rad/s.
        """
        self._check_open()
        t = self._check_tensions(tensions)
        self._tensions = t
        q, qd = self._integrator.advance(t, self.n_substeps, self._tick)
        if not self._integrator.finite_and_bounded(q, qd):
            raise self._diverged("the simulation diverged", q, qd, t)

    @property
    def tip(self) -> np.ndarray:
        """Tip-disk centre in R0, shape (3,), m."""
        return self._to_base(self.tip_world)

    @property
    def tip_world(self) -> np.ndarray:
        """Tip-disk centre in the world frame, shape (3,), m (= :attr:`tip` when upright)."""
        self._check_open()
        return self._read_points()[0][-1].copy()

    @property
    def cable_lengths(self) -> np.ndarray:
        """Sensed cable lengths (C,), m: each cable's path from the base disk to its section's
        last disk (distal cables include their run through proximal sections): its straight
        segments, pinhole to pinhole or between the via-points of ``"corrected"`` routing
        (``DiscreteBackbone.cable_lengths``)."""
        self._check_open()
        if self.routing == "disk":
            return self.chain.lengths_between_pinholes(self._read_points()[1])
        return self.chain.lengths_of_pose(self._read())

    @property
    def tensions(self) -> np.ndarray:
        """Cable tensions currently applied, (C,), N."""
        return self._tensions.copy()

    @property
    def joint_positions(self) -> np.ndarray:
        """Joint angles q (2n,), rad, ordered [a_1, b_1, a_2, b_2, ...] (X then Y per joint)."""
        self._check_open()
        return self._state()[0].copy()

    @property
    def joint_velocities(self) -> np.ndarray:
        """Joint rates q̇ (2n,), rad/s, ordered like :attr:`joint_positions`."""
        self._check_open()
        return self._state()[1].copy()

    @property
    def stiffness(self) -> np.ndarray:
        """Diagonal joint stiffness K (2n,), N·m/rad (EI/Δ_j for both coordinates of joint j)."""
        return self._integrator.K.copy()

    @property
    def damping(self) -> np.ndarray:
        """Diagonal joint damping D (2n,), N·m·s/rad."""
        return self._integrator.D.copy()

    def set_joint_state(self, q: np.ndarray, qd: np.ndarray | None = None) -> None:
        """Low-level: set the joint angles ``q`` (2n,) rad and rates ``qd`` (2n,) rad/s.

        For tests and analysis (virtual-work checks at arbitrary poses); the env never calls it.
        """
        self._check_open()
        q = np.asarray(q, dtype=np.float64)
        qd = np.zeros(self.n_dof) if qd is None else np.asarray(qd, dtype=np.float64)
        if q.shape != (self.n_dof,) or qd.shape != (self.n_dof,):
            raise ValueError(f"q and qd must have shape ({self.n_dof},), got {q.shape}, {qd.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise ValueError("q and qd must be finite")
        self._set_state(q, qd)

    def cable_generalized_forces(self, tensions: np.ndarray | None = None) -> np.ndarray:
        """The generalized joint forces τ = −Σ_i T_i ∂l_i/∂q (2n,), N·m, at the current pose.

        ``tensions`` (C,) N defaults to the tensions currently applied.
        """
        self._check_open()
        t = self._tensions if tensions is None else self._check_tensions(tensions)
        return self.chain.cable_loads(self._state()[0], t)[0]

    def gravity_generalized_forces(self) -> np.ndarray:
        """Generalized gravity forces (2n,), N·m, at the current pose (pybullet inverse dynamics)."""
        self._check_open()
        return -self._integrator.gravity_bias(self._state()[0])

    def mass_matrix(self) -> np.ndarray:
        """Joint-space mass matrix M(q) (2n, 2n) at the current pose, from pybullet."""
        self._check_open()
        return np.asarray(
            self._pb.calculateMassMatrix(
                self._body, self._state()[0].tolist(), physicsClientId=self._client
            )
        )

    def backbone_points(self, index: int = 0, frame: str = "base") -> np.ndarray:
        """Backbone polyline (2n+1, 3), m: base, then per link its joint and its station, tip last.

        Every disk station is a point (the disks sit at the link centres; the tip disk is the
        last point). ``frame="base"`` (default) gives R0 coordinates, ``"world"`` pybullet's.
        """
        if frame not in ("base", "world"):
            raise ValueError(f"frame must be 'base' or 'world', got {frame!r}")
        self._check_open()
        pose = self._read()
        pts = np.empty((2 * self.n_links + 1, 3))
        pts[0] = 0.0
        pts[1::2] = pose.joint_points
        pts[2::2] = pose.stations[1:]
        return pts if frame == "world" else self._to_base(pts)

    def pinhole_positions(self, frame: str = "base") -> np.ndarray:
        """Cable pinholes (n_disks+1, C, 3), m: [disk (base first), cable, xyz], in R0 or world.

        Every cable's pinhole position on every disk; cable i passes only the disks of its own
        and the proximal sections (``chain.routed``)."""
        if frame not in ("base", "world"):
            raise ValueError(f"frame must be 'base' or 'world', got {frame!r}")
        self._check_open()
        pins = self._read_points()[1].copy()
        return pins if frame == "world" else self._to_base(pins)

    # -- copies -------------------------------------------------------------------------------
    def __getstate__(self) -> dict:
        """Refuse pickling, deepcopy and cloudpickle: the state lives in a pybullet client that a
        copy would share (stepping the copy would move the original). Build a new env instead;
        SB3's SubprocVecEnv pickles env *factories*, which keeps working."""
        raise copy_refused(type(self).__name__)

    # -- the batched Backend interface (N = 1) ------------------------------------------------
    num_robots = 1

    def _as_array(self, tensions) -> np.ndarray:
        try:
            return np.asarray(tensions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"tensions must be real numbers (N), {self.params.n_cables} per robot, "
                f"got {tensions!r}"
            ) from None

    def _robot_row(self, tensions: np.ndarray) -> np.ndarray:
        t = self._as_array(tensions)
        if t.ndim == 2 and t.shape[0] == 1:
            t = t[0]
        return t

    def reset(self, tensions: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Rest in the static equilibrium under ``tensions`` (1, C) N (``mask`` (1,) bool)."""
        if mask is not None and not bool(np.asarray(mask).reshape(-1)[0]):
            return
        self._reset_robot(self._robot_row(tensions))

    def apply_tensions(self, tensions: np.ndarray) -> None:
        """Hold ``tensions`` (1, C) N for one control step."""
        self._drive_state = None
        self._hold_tensions(self._robot_row(tensions))

    def enable_displacement_control(self) -> None:
        """Refuse displacement commands on a robot with cable friction or with an infinite
        ``tendon_stiffness`` (``ValueError``)."""
        if not np.isfinite(self.params.cable_stiffness).all():
            raise ValueError(
                f"tendon_stiffness must be finite (N/m) for displacement commands on the "
                f"pybullet backend, got {self.params.tendon_stiffness!r}"
            )
        if self.friction_coefficient > 0.0:
            raise ValueError(
                f"displacement commands on the pybullet backend need frictionless cables, "
                f"got friction_coefficient={self.friction_coefficient!r} (use the MuJoCo "
                f"backend for friction with displacement commands)"
            )

    @property
    def straight_cable_lengths(self) -> np.ndarray:
        """The cables' lengths (C,) m at the straight pose (L0 of the drives)."""
        zeros = np.zeros(self.n_dof)
        return self.chain.cable_loads(zeros, np.zeros(self.params.n_cables))[1].copy()

    def apply_displacements(self, displacements: np.ndarray) -> None:
        """Hold drive displacements ``displacements`` (1, C) m for one control step (the
        module docstring); :meth:`read` then reports the law's tensions at the final shape.
        With a compliant base (``base_compliance`` c > 0) the drives' commands carry the
        base's give c·(ΣT − ΣT0) of the coupled law at the shape the step starts from.

        Raises:
            ValueError: naming ``displacements`` for a wrong shape or non-finite values, or
                with cable friction (:meth:`enable_displacement_control`).
            SimulationDivergedError: as :meth:`apply_tensions`.
        """
        self._check_open()
        c = self.params.n_cables
        d = validation.real_array(displacements, "displacements", (1, c))[0].copy()
        self.enable_displacement_control()
        p = self.params
        if self._straight is None:
            self._straight = self.straight_cable_lengths
        straight = self._straight
        k = np.asarray(p.cable_stiffness, dtype=np.float64)
        t0 = np.asarray(p.cable_pretension, dtype=np.float64)
        drive = (k, t0, self.drive_max_tension, straight)
        command = d
        if p.base_compliance > 0.0:
            # the compliant base couples the tendons (every drive loses c·Σ(T − T0)): the
            # coupled law solved at the current lengths, the integrator's drives get the
            # command less the base's give (exact at rest; as the MuJoCo drives)
            now = self.chain.cable_loads(self._integrator.state()[0], np.zeros(c))[1]
            t_now = drive_tensions(p, d, straight - now, drive[2])[0]
            command = d - p.base_compliance * float(t_now.sum() - t0.sum())
        q, qd = self._integrator.advance_displacements(command, drive, self.n_substeps, self._tick)
        lengths = self.chain.cable_loads(q, np.zeros(c))[1]
        tensions, slack, saturated = drive_tensions(p, d, straight - lengths, drive[2])
        self._tensions = tensions
        self._drive_state = DriveState(d[None].copy(), slack[None], saturated[None])
        if not self._integrator.finite_and_bounded(q, qd):
            raise self._diverged("the simulation diverged", q, qd, tensions)

    @property
    def drive_state(self) -> DriveState | None:
        return self._drive_state

    def _direction(self, pose_rot: np.ndarray) -> np.ndarray:
        return self._to_base(pose_rot[-1][:, 2])

    def read(self) -> Readings:
        self._check_open()
        pose = self._read()
        return Readings(
            self.tip[None],
            self._direction(pose.link_rot)[None],
            self.cable_lengths[None],
            self._tensions.copy()[None],
            self.anchor_tensions[None] if self._report_anchors else None,
        )

    def set_randomized(self, index: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Apply drawn ``youngs_modulus`` (Pa; joint stiffness and damping, the damping ratio
        kept), ``friction_coefficient`` and ``gravity`` (1.0 on, 0.0 off) to this robot (index
        0), in the running pybullet client: nothing is rebuilt. Masses, payload and base tilt
        would need a new multibody and are not applied (reported only)."""
        if "friction_coefficient" in values:
            mu = float(values["friction_coefficient"][0])
            if not 0.0 <= mu <= 1.0:
                raise ValueError(f"friction_coefficient must be in [0, 1], got {mu!r}")
            self.friction_coefficient = self._integrator.friction_coefficient = mu
            self._report_anchors = True  # the same info keys in every episode
        if "gravity" in values:
            on = bool(values["gravity"][0] > 0.5)
            self.gravity = on  # pybullet (dynamics and statics); the chain model keeps its own
            g = -STANDARD_GRAVITY if on else 0.0
            self._pb.setGravity(0.0, 0.0, g, physicsClientId=self._client)
            self._integrator.set_gravity_in_base(self._tilted_gravity if on else None)
        if "youngs_modulus" in values:
            e = float(values["youngs_modulus"][0])
            self.chain.stiffness = self._nominal_stiffness * (e / self.params.youngs_modulus)
        if "youngs_modulus" in values or "gravity" in values:  # keep ζ of the first mode
            self._integrator.set_stiffness(self.chain.stiffness, backend_damping_time(self))

    @property
    def segment_tensions(self) -> np.ndarray:
        """Tension (n_disks, C) N in every cable segment (row k: disk k to k + 1; rows beyond
        a cable's anchor are not part of it) at the current state and slip."""
        self._check_open()
        return self._integrator.segment_tensions(self._state()[0], self._tensions)

    @property
    def anchor_tensions(self) -> np.ndarray:
        """Tension (C,) N in each cable's last segment, at its anchor disk (= the actuator
        tension without friction)."""
        if self.friction_coefficient == 0.0:
            return self._tensions.copy()
        last = self.chain.routed.sum(axis=0) - 1  # index of each cable's last span
        return self.segment_tensions[last, np.arange(self.params.n_cables)]

    @property
    def slip(self) -> np.ndarray:
        """Slip state (C,) of the cables in [−1, 1]: +1 pulled, −1 released, between: stick."""
        return self._integrator.slip.copy()

    def equilibrium(self, tensions: np.ndarray) -> Readings:
        """Static equilibria under ``tensions`` (M, C) N, without changing the state.

        Each is :meth:`static_equilibrium` (gravity as configured): the reachable set of this
        backend, from which the task draws its goals and the env its random starts."""
        return self._statics(tensions, None)

    def _drive_equilibrium(self, tensions: np.ndarray) -> Readings:
        return self._statics(tensions, self.drive_max_tension)

    def _statics(self, tensions: np.ndarray, limit: float | None) -> Readings:
        """:meth:`equilibrium` with the tensions checked to lie in [0, ``limit``] (None:
        ``params.max_tension``)."""
        self._check_open()
        t_all = np.atleast_2d(self._as_array(tensions))
        if t_all.ndim != 2:
            raise ValueError(
                f"tensions must have shape (M, {self.params.n_cables}) (N), got shape {t_all.shape}"
            )
        tips, dirs, lengths = [], [], []
        for t in t_all:
            q = self._static_q(self._check_tensions(t, limit))
            pose = self.chain.pose(q)
            tips.append(self._to_base(pose.stations[-1]))
            dirs.append(self._direction(pose.link_rot))
            lengths.append(self.chain.lengths_of_pose(pose))
        return Readings(np.array(tips), np.array(dirs), np.array(lengths), t_all.copy())

    def disk_frames(self, index: int = 0) -> tuple[np.ndarray, np.ndarray]:
        self._check_open()
        pose = self._read()
        stride = self.links_per_span
        centres = self._to_base(pose.stations[::stride])
        rots = np.concatenate(
            [
                np.eye(3)[None] @ self._base_rot.T @ self._base_rot,
                pose.link_rot[stride - 1 :: stride],
            ]
        )
        rots = np.einsum("ji,njk->nik", self._base_rot, rots)
        return centres, rots

    def close(self) -> None:
        """Disconnect the pybullet client. Safe to call more than once."""
        if getattr(self, "_client", None) is None:
            return
        if self._connection is not None:
            self._connection.close()
        self._connection = None
        self._client = None
        self._invalidate()
