"""pybullet multibody backend: the backbone as a chain of rigid links with elastic 2-DOF joints.

The model (derivations and measured numbers in ``docs/bullet_backend.md``)
=========================================================================

The discretised backbone (``cdcr_gym.backends.bullet_chain.DiscreteBackbone``)
    Rigid links between the disks (``links_per_span`` per disk span) joined by Cardan joints
    (two revolutes, X then Y: bending without twist or extension) that sit half-way between
    the rod stations, so that every disk is centred on a link and every joint owns exactly Δs
    of rod: stiffness EI/Δs for all joints. Cable loads are the generalized forces
    τ = −Σ_i T_i ∂l_i/∂q of frictionless cables running straight between pinholes, computed
    from the one segment per cable that crosses each joint. The derivations, the joint
    placement and its convergence (span-mean moment-arm excess (1 + 2/m²)·h²κ/12) and the mass
    model are in that module's docstring; here only the dynamics.

pybullet's multibody
    The base (base disk, first half link) is fixed at the world origin with orientation
    ``base_orientation``; each Cardan joint is a revolute about X into a massless intermediate
    link at the joint, then a revolute about Y into the real link (mass, COM and principal
    inertia from the chain model; no collision shapes, so no contacts). pybullet's API caps a
    multibody at 128 coordinates including the base's 7, hence n_disks·links_per_span ≤ 60.

Implicit spring–damper integration
    pybullet has no joint springs. The default motors are switched off and every physics step
    applies a joint torque. The joints are stiff against the light links (9 links: highest mode
    ω_max ≈ 3 600 rad/s, the half tip link with its disk; an explicit spring would need
    h < 2/ω_max ≈ 0.55 ms, explicit damping less), so stiffness and damping are treated by
    backward Euler: with M = ``calculateMassMatrix(q)`` and b(q, q̇) =
    ``calculateInverseDynamics(q, q̇, 0)`` (gravity + Coriolis; pybullet evaluates it as if the
    base were upright, so for a turned base gravity is set to its R0 components for that call),
    (M + hD + h²K)·Δq̇ = h·(τ_cable − b − K·q − (D + hK)·q̇),   q̇⁺ = q̇ + Δq̇,
    and the torque sent to pybullet is τ = τ_cable − K·(q + h·q̇⁺) − D·q̇⁺. pybullet's own
    semi-implicit Euler step (q̇⁺ = q̇ + h·M⁻¹(τ − b), q⁺ = q + h·q̇⁺) then reproduces the
    backward-Euler update exactly, which is unconditionally stable for the linear spring and
    damper. Cable and gravity loads stay explicit: their stiffness (the cables' ≈ ΣT·Δs/4 per
    joint, ≤ 4.3 N·m/rad at 3 × 80 N with 9 links; gravity's ≲ 0.4 N·m/rad) is a fraction of
    K = EI/Δs = 15.1 N·m/rad, which keeps the step stable (checked to h = 0.1 s). A state at
    rest is a fixed point of the update iff K·q = τ_cable(q) − b(q, 0): the settled state is
    the static solution, independent of h. The default h = 0.01 s (two steps per 0.02 s
    control step) resolves the first mode (ω₁·h ≈ 0.19) and meets the speed target; h = 0.02 s
    is ≈ 1.7× as fast, with the same equilibria and similar settling (docs).

Damping
    Per-joint, stiffness-proportional (Kelvin–Voigt material damping of the rod): D = β·K with
    β = 2ζ/ω₁, where ω₁ is the first bending mode of the linearised chain at the straight pose
    (generalized eigenproblem K·v = ω²·M·v, computed at construction) and ζ = ``damping_ratio``.
    Higher modes are over-damped and relax at ≈ 1/β = ω₁/(2ζ); the default ζ = 0.7 balances the
    first mode (decay ζω₁) against those, for the fastest settling (numbers in the docs).

Frames
    The base frame R0 is the base disk centre with the backbone along +Z0 and cable 1 at +X0.
    ``base_orientation`` places R0 in the world (pybullet's frame, gravity −Z_world). Every
    position this backend returns (:attr:`tip`, :meth:`backbone_points`) is expressed in R0
    unless stated otherwise (:attr:`tip_world`, ``backbone_points(frame="world")``).
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import math
import os
import sys
import time
import weakref
from collections.abc import Iterator, Sequence

import numpy as np

from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.backends.bullet_chain import GRAVITY, ChainPose, DiscreteBackbone, quat_to_matrix
from cdcr_gym.params import RobotParams

__all__ = ["BulletBackend", "SimulationDivergedError"]

#: A joint whose angle exceeds this (rad) or whose rate exceeds ``_MAX_JOINT_RATE`` (rad/s) is
#: taken as a diverged simulation (a real spacer-disk span never kinks by 90°).
_MAX_JOINT_ANGLE = 0.5 * math.pi
_MAX_JOINT_RATE = 1.0e3
#: Most Cardan joints (n_disks × links_per_span) one pybullet multibody can hold: pybullet's
#: shared-memory state holds 128 coordinates per body, 7 of them the base pose, so joint
#: states from index 121 on are lost (measured with pybullet 3.2.7): 60 joints = 120 revolutes.
MAX_JOINTS = 60


class SimulationDivergedError(RuntimeError):
    """The simulation produced a non-finite or exploding state.

    Attributes:
        state: dict with the offending ``joint_positions`` (rad), ``joint_velocities`` (rad/s),
            ``tensions`` (N) and simulated ``time`` (s), as numpy arrays / float.
    """

    def __init__(self, message: str, state: dict):
        super().__init__(message)
        self.state = state


# --------------------------------------------------------------------------------------------
# pybullet import and connection without start-up banners
# --------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _silenced_stdio() -> Iterator[None]:
    """Redirect the C-level file descriptors 1 and 2 to /dev/null for the duration.

    pybullet prints banners from C (``pybullet build time`` at import, GL/thread information
    at connect) straight to the process's stdout/stderr, bypassing ``sys.stdout``. We flush
    Python's and C's buffers, point fds 1 and 2 at /dev/null, and restore them afterwards.
    Output written by other threads in that short window is lost as well.
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    libc = _libc()
    if libc is not None:
        libc.fflush(None)
    saved = []
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # pragma: no cover - no /dev/null: just run unsilenced
        yield
        return
    try:
        for fd in (1, 2):
            try:
                saved.append((fd, os.dup(fd)))
                os.dup2(devnull, fd)
            except OSError:  # pragma: no cover - fd not open
                pass
        yield
    finally:
        if libc is not None:
            libc.fflush(None)
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


_LIBC: ctypes.CDLL | None | bool = False


def _libc() -> ctypes.CDLL | None:
    global _LIBC
    if _LIBC is False:
        try:
            _LIBC = ctypes.CDLL(None)
        except OSError:  # pragma: no cover
            _LIBC = None
    return _LIBC  # type: ignore[return-value]


_PYBULLET = None


def _pybullet():
    """Import pybullet once, silently (its import prints a build-time banner from C)."""
    global _PYBULLET
    if _PYBULLET is None:
        if "pybullet" in sys.modules:
            import pybullet
        else:
            with _silenced_stdio():
                import pybullet
        _PYBULLET = pybullet
    return _PYBULLET


def _disconnect(client: int) -> None:
    """Disconnect a pybullet client if it is still connected (finalizer; never raises)."""
    pb = _PYBULLET
    if pb is None:  # pragma: no cover
        return
    with contextlib.suppress(Exception):
        if pb.getConnectionInfo(physicsClientId=client)["isConnected"]:
            pb.disconnect(physicsClientId=client)


# --------------------------------------------------------------------------------------------
# the backend
# --------------------------------------------------------------------------------------------


def _check_bool(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a bool, got {value!r}")
    return bool(value)


def _check_positive(name: str, value, unit: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"{name} must be a real number ({unit}), got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be finite and > 0 {unit}, got {value!r}")
    return value


class BulletBackend(Backend):
    """The CDCR backbone simulated as a pybullet multibody (see the module docstring).

    Args:
        params: the robot (:class:`~cdcr_gym.params.RobotParams`; default: the paper's Table 1).
        gravity: ``True`` (default) applies −9.81 m/s² along −Z_world; ``False`` switches
            gravity off (the paper's simulation and the pure-moment statics have none).
        links_per_span: rigid links per disk span, m >= 1 (default 1): the chain has
            ``n_disks·m`` links and twice as many revolute joints. Larger m converges to a
            continuous rod between the disks (the span-mean cable moment-arm excess is
            (1 + 2/m²) times the physical one, see ``bullet_chain``) at a cost in speed (m = 4:
            ≈ 4.7× slower). Use m = 4 for quantitative studies of the 9-disk robot (tip within
            0.5 mm of the m → ∞ limit at 40 N, 1.8 mm at 80 N). n_disks·m <= 60 (pybullet).
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
        gui: open the pybullet GUI (``render_mode="human"``) instead of a headless client
            (default ``False``). pybullet allows one GUI client per process.
        damping_ratio: damping ratio ζ > 0 of the first bending mode (default 0.7); the joint
            damping is D = (2ζ/ω₁)·K. Larger values settle the first mode without overshoot
            but slow the higher modes (rate ω₁/(2ζ)).

    Raises:
        ValueError: naming the argument and the value, for any invalid argument.
    """

    supports_length_control = False

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
    ) -> None:
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        self.params = params
        self.gravity = _check_bool("gravity", gravity)
        self.gui = _check_bool("gui", gui)
        if (
            isinstance(links_per_span, (bool, np.bool_))
            or not isinstance(links_per_span, (int, np.integer))
            or links_per_span < 1
        ):
            raise ValueError(f"links_per_span must be an integer >= 1, got {links_per_span!r}")
        if params.n_sections != 1 or params.n_cables != 3:
            raise ValueError(
                f"params: the pybullet backend models one section with three cables; got "
                f"{params.n_sections} sections and {params.n_cables} cables (use the CCKA "
                f"backend for several sections)"
            )
        self.links_per_span = int(links_per_span)
        self.control_timestep = _check_positive("control_timestep", control_timestep, "s")
        self.physics_timestep = _check_positive("physics_timestep", physics_timestep, "s")
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
        if (
            isinstance(tip_payload, (bool, np.bool_))
            or not isinstance(tip_payload, (int, float, np.integer, np.floating))
            or not math.isfinite(float(tip_payload))
            or float(tip_payload) < 0.0
        ):
            raise ValueError(f"tip_payload must be finite and >= 0 kg, got {tip_payload!r}")
        self.tip_payload = float(tip_payload)
        self.damping_ratio = _check_positive("damping_ratio", damping_ratio, "")

        p = params
        if p.n_disks * self.links_per_span > MAX_JOINTS:
            raise ValueError(
                f"params.n_disks × links_per_span = {p.n_disks} × {self.links_per_span} = "
                f"{p.n_disks * self.links_per_span} joints, but a pybullet multibody holds at most "
                f"{MAX_JOINTS} (its state holds 121 joint coordinates); use fewer disks or links per span "
                "(cdcr_gym.backends.bullet_chain.DiscreteBackbone evaluates longer chains' statics)"
            )
        self._base_rot = quat_to_matrix(np.asarray(self.base_orientation))
        #: The discretised backbone: geometry, masses, cable and gravity loads, statics.
        self.chain = DiscreteBackbone(
            p, self.links_per_span, self.tip_payload, self._base_rot, self.gravity
        )
        self.n_links = self.chain.n_links  # links = 2-DOF joints
        self.n_dof = self.chain.n_dof  # revolute coordinates, 2 per joint
        self.segment_length = self.chain.segment_length  # Δs, m
        #: Joint stiffness EI/Δs (N·m/rad), the same for all 2n revolute coordinates.
        self.joint_stiffness = self.chain.joint_stiffness
        self._tensions = np.zeros(3)
        self._pose: ChainPose | None = None
        self._points: tuple[np.ndarray, np.ndarray] | None = None
        # gravity in R0 coordinates, when it differs from the upright (0, 0, −g) (see _bias)
        g_base = self._base_rot.T @ np.array([0.0, 0.0, -GRAVITY])
        upright = np.allclose(g_base, (0.0, 0.0, -GRAVITY), rtol=0.0, atol=1e-12)
        self._gravity_in_base = None if (upright or not self.gravity) else tuple(g_base.tolist())
        self._q: np.ndarray | None = None
        self._qd: np.ndarray | None = None
        self.time = 0.0
        self._last_human_render = None

        self._pb = _pybullet()
        pb = self._pb
        with _silenced_stdio():
            self._client = pb.connect(pb.GUI if self.gui else pb.DIRECT)
        if self._client < 0:
            raise RuntimeError("pybullet could not connect (a GUI may already be open)")
        self._finalizer = weakref.finalize(self, _disconnect, self._client)
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        self.reset(np.zeros(3))

    # ---------------------------------------------------------------- construction

    def _build(self) -> None:
        pb, cid = self._pb, self._client
        ds = self.segment_length
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.physics_timestep,
            numSubSteps=0,
            deterministicOverlappingPairs=1,
            physicsClientId=cid,
        )
        pb.setGravity(0.0, 0.0, -GRAVITY if self.gravity else 0.0, physicsClientId=cid)
        if self.gui:
            pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=cid)
            target = self._base_rot @ np.array([0.0, 0.0, 0.4 * self.params.length])
            pb.resetDebugVisualizerCamera(
                1.9 * self.params.length, 30.0, -20.0, target.tolist(), physicsClientId=cid
            )

        vis = self._make_visuals()
        masses, vis_idx, pos, inertial_pos, parents, axes = [], [], [], [], [], []
        chain = self.chain
        for j in range(1, self.n_links + 1):
            mass, z_c = float(chain.link_masses[j - 1]), float(chain.link_com_offsets[j - 1])
            # X joint into the massless intermediate link
            masses.append(0.0)
            vis_idx.append(-1)
            pos.append((0.0, 0.0, 0.5 * ds if j == 1 else ds))
            inertial_pos.append((0.0, 0.0, 0.0))
            parents.append(len(parents))
            axes.append((1.0, 0.0, 0.0))
            # Y joint into the real link
            masses.append(mass)
            vis_idx.append(
                vis["tip"]
                if j == self.n_links
                else (vis["disk"] if j % self.links_per_span == 0 else vis["rod"])
            )
            pos.append((0.0, 0.0, 0.0))
            inertial_pos.append((0.0, 0.0, z_c))
            parents.append(len(parents))
            axes.append((0.0, 1.0, 0.0))
        n2 = self.n_dof
        self._body = pb.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            baseVisualShapeIndex=vis["base"],
            basePosition=(0.0, 0.0, 0.0),
            baseOrientation=self.base_orientation,
            linkMasses=masses,
            linkCollisionShapeIndices=[-1] * n2,
            linkVisualShapeIndices=vis_idx,
            linkPositions=pos,
            linkOrientations=[(0.0, 0.0, 0.0, 1.0)] * n2,
            linkInertialFramePositions=inertial_pos,
            linkInertialFrameOrientations=[(0.0, 0.0, 0.0, 1.0)] * n2,
            linkParentIndices=parents,
            linkJointTypes=[pb.JOINT_REVOLUTE] * n2,
            linkJointAxis=axes,
            physicsClientId=cid,
        )
        body = self._body
        # No collision shapes, so pybullet would give the links zero inertia: set it. No
        # built-in velocity damping, no velocity clamp below our divergence limit, no sleeping.
        pb.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        for i in range(n2):
            kw = dict(
                linearDamping=0.0,
                angularDamping=0.0,
                jointDamping=0.0,
                maxJointVelocity=10.0 * _MAX_JOINT_RATE,
                activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
                physicsClientId=cid,
            )
            pb.changeDynamics(body, i, **kw)
            if i % 2 == 1:
                # a separate call: combined with the damping keywords above, pybullet 3.2.7
                # silently ignores localInertiaDiagonal
                pb.changeDynamics(
                    body,
                    i,
                    localInertiaDiagonal=chain.link_inertias[i // 2].tolist(),
                    physicsClientId=cid,
                )
        self._joint_ids = list(range(n2))
        for i in range(1, n2, 2):
            info = pb.getDynamicsInfo(body, i, physicsClientId=cid)
            if not np.allclose(info[2], chain.link_inertias[i // 2], rtol=1e-9, atol=0.0):
                raise RuntimeError(f"pybullet did not take the inertia of link {i}: {info[2]}")
        # default joint motors off (they would act as velocity dampers)
        pb.setJointMotorControlArray(
            body, self._joint_ids, pb.VELOCITY_CONTROL, forces=[0.0] * n2, physicsClientId=cid
        )
        self._zeros_list = [0.0] * n2
        self._goal_body = pb.createMultiBody(
            baseMass=0.0,
            baseVisualShapeIndex=vis["goal"],
            basePosition=(0.0, 0.0, -100.0),
            physicsClientId=cid,
        )

        grey, orange = (0.55, 0.57, 0.62, 1.0), (0.95, 0.55, 0.1, 1.0)
        for link in range(-1, n2):
            colour = orange if link == n2 - 1 else grey
            pb.changeVisualShape(body, link, rgbaColor=colour, physicsClientId=cid)

        # stiffness and damping
        self._K = np.full(n2, self.joint_stiffness)
        mass0 = np.asarray(pb.calculateMassMatrix(body, self._zeros_list, physicsClientId=cid))
        # modes of the linearised chain, K v = ω² M v with K = k·I: ω² = k / eig(M)
        eig = np.linalg.eigvalsh(mass0)  # ascending
        #: Angular frequency ω₁ (rad/s) of the first bending mode at the straight pose, and of
        #: the highest mode ω_max (what an explicit integrator would have to resolve).
        self.first_mode_frequency = float(math.sqrt(self.joint_stiffness / eig[-1]))
        self.highest_mode_frequency = float(math.sqrt(self.joint_stiffness / eig[0]))
        #: Stiffness-proportional damping time β = 2ζ/ω₁ (s): D = β·K.
        self.damping_time = 2.0 * self.damping_ratio / self.first_mode_frequency
        self._D = self.damping_time * self._K
        h = self.physics_timestep
        self._A_diag = h * self._D + h * h * self._K
        self._D_plus_hK = self._D + h * self._K

    def _make_visuals(self) -> dict:
        pb, cid, p = self._pb, self._client, self.params
        ds = self.segment_length
        rod_r = max(0.5 * p.backbone_diameter, 0.003)  # drawn a little thicker to be visible

        def shape(kind, rgba, **kw):
            return pb.createVisualShape(kind, rgbaColor=rgba, physicsClientId=cid, **kw)

        def array(parts):
            return pb.createVisualShapeArray(
                shapeTypes=[k for k, _, _ in parts],
                radii=[r for _, r, _ in parts],
                lengths=[ln for _, _, (ln, _) in parts],
                visualFramePositions=[pos for _, _, (_, pos) in parts],
                physicsClientId=cid,
            )

        cyl, sph = pb.GEOM_CYLINDER, pb.GEOM_SPHERE
        rod = (cyl, rod_r, (ds, (0.0, 0.0, 0.5 * ds)))
        disk = (cyl, p.disk_radius, (p.disk_thickness, (0.0, 0.0, 0.5 * ds)))
        tip_rod = (cyl, rod_r, (0.5 * ds, (0.0, 0.0, 0.25 * ds)))
        holes = [
            (sph, 0.004, (0.0, (float(x), float(y), 0.5 * ds + 0.5 * p.disk_thickness)))
            for x, y, _ in self.chain.pinhole_local
        ]
        base_rod = (cyl, rod_r, (0.5 * ds, (0.0, 0.0, 0.25 * ds)))
        base_disk = (cyl, p.disk_radius, (p.disk_thickness, (0.0, 0.0, 0.0)))
        out = {
            "rod": array([rod]),
            "disk": array([rod, disk]),
            "tip": array([tip_rod, disk] + holes),
            "base": array([base_rod, base_disk]),
            "goal": shape(sph, (0.55, 0.1, 0.75, 1.0), radius=0.012),
        }
        return out

    # ---------------------------------------------------------------- state access

    def _check_open(self) -> None:
        if self._client is None:
            raise RuntimeError("this BulletBackend is closed")

    def _state(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles q (2n,) rad and rates q̇ (2n,) rad/s from pybullet (cached until a step)."""
        if self._q is None:
            js = self._pb.getJointStates(self._body, self._joint_ids, physicsClientId=self._client)
            n = self.n_dof
            self._q = np.fromiter((s[0] for s in js), np.float64, n)
            self._qd = np.fromiter((s[1] for s in js), np.float64, n)
        return self._q, self._qd

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
        """World stations (n+1, 3) and pinholes (n_disks+1, 3, 3), m, of the current state.

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
        """Drop the cached state and geometry (after every change of the pybullet state)."""
        self._q = self._qd = self._pose = self._points = None

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
        self._pb.resetJointStatesMultiDof(
            self._body,
            self._joint_ids,
            [[float(v)] for v in q],
            targetVelocities=[[float(v)] for v in qd],
            physicsClientId=self._client,
        )
        self._invalidate()

    def _diverged(
        self, message: str, q: np.ndarray, qd: np.ndarray, t: np.ndarray
    ) -> SimulationDivergedError:
        state = {
            "joint_positions": q.copy(),
            "joint_velocities": qd.copy(),
            "tensions": t.copy(),
            "time": self.time,
        }
        return SimulationDivergedError(
            f"{message} (t = {self.time:.4f} s, tensions {t.tolist()} N, "
            f"max |q| = {np.max(np.abs(q))} rad, max |q̇| = {np.max(np.abs(qd))} rad/s)",
            state,
        )

    # ---------------------------------------------------------------- Backend API

    def _check_tensions(self, tensions) -> np.ndarray:
        t = np.array(tensions, dtype=np.float64)  # a copy
        if t.shape != (3,):
            raise ValueError(f"tensions must have shape (3,) (N), got {tensions!r}")
        lo, hi = t.min(), t.max()
        if not (0.0 <= lo and hi <= self.params.max_tension):  # also catches NaN
            raise ValueError(
                f"tensions must be finite and in [0, max_tension={self.params.max_tension}] N, "
                f"got {tensions!r}"
            )
        return t

    def _bias(self, q_list: list, qd_list: list) -> np.ndarray:
        """b(q, q̇) = C(q, q̇)·q̇ + g(q): the joint torques (N·m) for zero acceleration.

        pybullet's ``calculateInverseDynamics`` works in the base frame and applies the world
        gravity vector there as if the base were upright (pybullet 3.2.7). For a turned base we
        therefore set gravity to its base-frame components R0ᵀ·g around the call (a test checks
        the result against the chain model's gravity loads).
        """
        pb, cid = self._pb, self._client
        if self._gravity_in_base is None:
            return np.array(
                pb.calculateInverseDynamics(
                    self._body, q_list, qd_list, self._zeros_list, physicsClientId=cid
                )
            )
        pb.setGravity(*self._gravity_in_base, physicsClientId=cid)
        try:
            return np.array(
                pb.calculateInverseDynamics(
                    self._body, q_list, qd_list, self._zeros_list, physicsClientId=cid
                )
            )
        finally:
            pb.setGravity(0.0, 0.0, -GRAVITY, physicsClientId=cid)

    def _gravity_bias(self, q: np.ndarray) -> np.ndarray:
        """b(q, 0): the joint torques that hold the chain still against gravity (N·m)."""
        return self._bias(q.tolist(), self._zeros_list)

    def static_equilibrium(self, tensions: np.ndarray) -> np.ndarray:
        """Joint angles q (2n,) rad of the static equilibrium under ``tensions`` (3,) N.

        Solves K·q = τ_cable(q) − b(q, 0) (b from pybullet's inverse dynamics: gravity) by the
        fixed-point iteration q ← K⁻¹·(τ_cable(q) − b(q, 0)) from the straight pose, to
        max |Δq| < 1e-14 rad. It converges because the cable and gravity load stiffnesses are
        small against K (contraction factor ≈ 0.1–0.3 at the maximum tension); the limit is the
        stable equilibrium the dynamics settle to. Does not change the simulation state.

        Raises:
            SimulationDivergedError: if the iteration does not converge in 1000 steps. This
                happens when the tensions bowstring the chain: with only 1–2 disks and one link
                per span (moment-arm excess 3× the physical one) there is no equilibrium short
                of a 90° kink from about 20–40 N; 3 or more disks are fine up to 80 N.
        """
        self._check_open()
        t = self._check_tensions(tensions)
        q, converged = self.chain.static_equilibrium(
            t, self._gravity_bias, max_angle=_MAX_JOINT_ANGLE
        )
        if not converged:
            raise self._diverged(
                "no static equilibrium found: the cables' destabilising load stiffness (which grows "
                "with the disk spacing, see bullet_chain) exceeds the joint stiffness; with very "
                "few disks use more links_per_span or lower tensions",
                q,
                np.zeros(self.n_dof),
                t,
            )
        return q

    def _reset_one(self, tensions: np.ndarray) -> None:
        """Put the chain at rest in its static equilibrium under ``tensions`` (3,) N.

        Sets q = :meth:`static_equilibrium` (tensions) and q̇ = 0 and the simulated
        :attr:`time` to 0. The result depends only on ``tensions`` and the constructor
        arguments (the solver always starts from the straight pose), so the same call gives
        bit-identical state whatever happened before; :meth:`apply_tensions` with the same
        tensions then leaves the chain at rest.

        Raises:
            ValueError: if ``tensions`` is not 3 finite values in [0, max_tension].
            SimulationDivergedError: if no equilibrium is found.
        """
        self._check_open()
        t = self._check_tensions(tensions)
        q = self.static_equilibrium(t)
        self._set_state(q, np.zeros(self.n_dof))
        self._tensions = t
        self.time = 0.0

    def _apply_one(self, tensions: np.ndarray) -> None:
        """Hold ``tensions`` (3,) N for one control step (``n_substeps`` physics steps).

        Each physics step: read q, q̇; τ_cable(q); M(q) and b(q, q̇) from pybullet; solve the
        backward-Euler system for q̇⁺; send τ = τ_cable − K(q + h q̇⁺) − D q̇⁺; step.

        Raises:
            ValueError: if ``tensions`` is not 3 finite values in [0, max_tension].
            SimulationDivergedError: if the state becomes non-finite, a joint bends beyond
                90° or turns faster than 1000 rad/s.
        """
        self._check_open()
        t = self._check_tensions(tensions)
        self._tensions = t
        pb, cid, body, ids = self._pb, self._client, self._body, self._joint_ids
        h, n2 = self.physics_timestep, self.n_dof
        K, D, D_plus_hK = self._K, self._D, self._D_plus_hK
        torque_mode = pb.TORQUE_CONTROL
        cable_loads = self.chain.cable_loads
        for _ in range(self.n_substeps):
            q, qd = self._state()
            ql = q.tolist()
            tau_c, _ = cable_loads(q, t)
            # M(q) comes as 2n tuples of 2n floats: fromiter over the flattened rows is the
            # cheapest conversion (np.array on the nested tuples costs ~2.5 µs more)
            rows = pb.calculateMassMatrix(body, ql, physicsClientId=cid)
            mass = np.fromiter(itertools.chain.from_iterable(rows), np.float64, n2 * n2).reshape(
                n2, n2
            )
            bias = self._bias(ql, qd.tolist())
            mass.reshape(-1)[:: n2 + 1] += self._A_diag  # the diagonal (a view): M + hD + h²K
            qd_new = qd + np.linalg.solve(mass, h * (tau_c - bias - K * q - D_plus_hK * qd))
            torque = tau_c - K * (q + h * qd_new) - D * qd_new
            # TORQUE_CONTROL torques accumulate until the next step: exactly one call per step
            pb.setJointMotorControlArray(
                body, ids, torque_mode, forces=torque.tolist(), physicsClientId=cid
            )
            pb.stepSimulation(physicsClientId=cid)
            self._invalidate()
            self.time += h
        q, qd = self._state()
        # NaN fails every comparison, so "not (x <= limit)" also catches non-finite values
        if not (np.max(np.abs(q)) <= _MAX_JOINT_ANGLE and np.max(np.abs(qd)) <= _MAX_JOINT_RATE):
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
        """Sensed cable lengths (3,), m: summed pinhole-to-pinhole segment lengths, base → tip disk."""
        self._check_open()
        return self.chain.lengths_between_pinholes(self._read_points()[1])

    @property
    def tensions(self) -> np.ndarray:
        """Cable tensions currently applied, (3,), N."""
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
        """Diagonal joint stiffness K (2n,), N·m/rad (EI/Δs each)."""
        return self._K.copy()

    @property
    def damping(self) -> np.ndarray:
        """Diagonal joint damping D (2n,), N·m·s/rad."""
        return self._D.copy()

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

        ``tensions`` (3,) N defaults to the tensions currently applied.
        """
        self._check_open()
        t = self._tensions if tensions is None else self._check_tensions(tensions)
        return self.chain.cable_loads(self._state()[0], t)[0]

    def gravity_generalized_forces(self) -> np.ndarray:
        """Generalized gravity forces (2n,), N·m, at the current pose (pybullet inverse dynamics)."""
        self._check_open()
        return -self._gravity_bias(self._state()[0])

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
        """Cable pinholes (n_disks+1, 3, 3), m: [disk (base first), cable, xyz], in R0 or world."""
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
        raise TypeError(
            "a BulletBackend (and an env holding one) cannot be pickled or copied: its state is a "
            "pybullet client the copy would share; make a new env with gymnasium.make(...) "
            "(SubprocVecEnv/AsyncVectorEnv take env factories and work)"
        )

    # -- the batched Backend interface (N = 1) ------------------------------------------------
    num_robots = 1

    def _one(self, tensions: np.ndarray) -> np.ndarray:
        t = np.asarray(tensions, dtype=np.float64)
        if t.ndim == 2 and t.shape[0] == 1:
            t = t[0]
        return t

    def reset(self, tensions: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Rest in the static equilibrium under ``tensions`` (1, 3) N (``mask`` (1,) bool)."""
        if mask is not None and not bool(np.asarray(mask).reshape(-1)[0]):
            return
        self._reset_one(self._one(tensions))

    def apply_tensions(self, tensions: np.ndarray) -> None:
        """Hold ``tensions`` (1, 3) N for one control step."""
        self._apply_one(self._one(tensions))

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
        )

    def equilibrium(self, tensions: np.ndarray) -> Readings:
        """Static equilibria (its own statics, gravity as configured) under ``tensions`` (M, 3)."""
        t_all = np.atleast_2d(np.asarray(tensions, dtype=np.float64))
        tips, dirs, lengths = [], [], []
        for t in t_all:
            q = self.static_equilibrium(t)
            pose = self.chain.pose(q)
            tips.append(self._to_base(pose.stations[-1]))
            dirs.append(self._direction(pose.link_rot))
            lengths.append(self.chain.lengths_between_pinholes(pose.pinholes))
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

    # ---------------------------------------------------------------- rendering

    def _place_goal(self, goal) -> None:
        pb = self._pb
        if goal is None:
            pos = (0.0, 0.0, -100.0)
        else:
            g = np.asarray(goal, dtype=np.float64)
            if g.shape != (3,) or not np.all(np.isfinite(g)):
                raise ValueError(f"goal must be 3 finite numbers (m, R0) or None, got {goal!r}")
            pos = tuple(float(v) for v in self._base_rot @ g)
        pb.resetBasePositionAndOrientation(
            self._goal_body, pos, (0, 0, 0, 1), physicsClientId=self._client
        )

    def render_rgb(self, goal: np.ndarray | None, width: int, height: int) -> np.ndarray:
        """Image (height, width, 3) uint8 from pybullet's headless TinyRenderer.

        The camera is fixed in the world (Z_world up; pybullet yaw 30°, pitch −20°, distance 1.9ℓ),
        aimed at the middle of the robot's workspace; the goal is a purple sphere and the tip
        link orange.
        """
        self._check_open()
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} must be a positive integer (pixels), got {v!r}")
        pb, cid = self._pb, self._client
        self._place_goal(goal)
        ell = self.params.length
        target = self._base_rot @ np.array([0.0, 0.0, 0.4 * ell])
        view = pb.computeViewMatrixFromYawPitchRoll(
            target.tolist(), 1.9 * ell, 30.0, -20.0, 0.0, 2, physicsClientId=cid
        )
        proj = pb.computeProjectionMatrixFOV(
            45.0, width / height, 0.01, 10.0 * ell, physicsClientId=cid
        )
        _, _, rgba, _, _ = pb.getCameraImage(
            int(width),
            int(height),
            view,
            proj,
            renderer=pb.ER_TINY_RENDERER,
            flags=pb.ER_NO_SEGMENTATION_MASK,
            physicsClientId=cid,
        )
        img = np.asarray(rgba, dtype=np.uint8).reshape(int(height), int(width), 4)
        return np.ascontiguousarray(img[:, :, :3])

    def render_human(self, goal: np.ndarray | None) -> None:
        """With ``gui=True``: move the goal marker and pace the GUI to real time.

        Without the GUI, falls back to the matplotlib window of the base class.
        """
        self._check_open()
        if not self.gui:
            super().render_human(goal)
            return
        self._place_goal(goal)
        now = time.perf_counter()
        if self._last_human_render is not None:
            wait = self.control_timestep - (now - self._last_human_render)
            if wait > 0:
                time.sleep(wait)
        self._last_human_render = time.perf_counter()

    def close(self) -> None:
        """Disconnect the pybullet client. Safe to call more than once."""
        if getattr(self, "_client", None) is None:
            return
        self._finalizer()
        self._client = None
        self._invalidate()
