"""The Gymnasium env: one robot, one task, one backend — the env core at N = 1."""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium as gym
import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend
from cdcr_gym.envs.core import CoreAttributes, EnvCore
from cdcr_gym.tasks.base import Task
from cdcr_gym.tasks.reach import Reach

__all__ = ["CDCREnv", "GoalCDCREnv", "RENDER_KEYS"]

_ONE = np.array([0])

#: The single env's own arguments (the vector env does not render); the others are
#: :class:`~cdcr_gym.envs.core.EnvCore`'s.
RENDER_KEYS = ("render_mode", "render_width", "render_height")


def one_env(outputs: tuple[Any, np.ndarray, np.ndarray, dict[str, Any]]) -> tuple[Any, ...]:
    """Env 0 of the core's batched (observation, reward, success, info) at N = 1: the
    observation's row (or the Dict of rows), the reward a float, success a bool, and ``info``
    with a Python scalar for a per-env number and env 0's row (a view) for a per-env array."""
    obs, reward, success, info = outputs
    if isinstance(obs, dict):
        obs = {key: value[0] for key, value in obs.items()}
    else:
        obs = obs[0]
    info = {key: value.item() if value.ndim == 1 else value[0] for key, value in info.items()}
    return obs, reward.item(), success.item(), info


class CDCREnv(CoreAttributes, gym.Env):
    r"""A cable-driven continuum robot that must do a task, by pulling its cables.

    ## Description
    A flexible backbone stands on a fixed base disk along +Z0; cables run through spacer disks
    at fixed positions (radius r, angle β) and each is anchored at the last disk of its
    section, so pulling cables bends the sections towards them (a cable also bends every
    section it passes). The robot is a *backend* object (``cdcr_gym.backends``): the analytic
    piecewise-constant-curvature model (``CCKA*-v0``), a pybullet multibody backbone
    (``Bullet*-v0``) or a MuJoCo chain with one tendon per cable (``MuJoCo*-v0``, the reference
    physics); what the agent must do is a *task* object (``cdcr_gym.tasks``). The
    default robot is the paper's (one section, ℓ = 0.641 m, r = 29 mm, cables at
    0°/120°/240°); ``robot="tdcr2"`` selects the two-section reference robot.

    ## Action Space
    ``Box(-1, 1, (C,), float32)``, one entry per cable (C = ``params.n_cables``; section by
    section, proximal first). Out-of-range actions are clipped; a non-finite or non-real action
    raises ``ValueError``. Meaning by ``action_mode`` (``cdcr_gym.envs.actuation``):

    | mode              | effect of a_i                                                        |
    |-------------------|----------------------------------------------------------------------|
    | ``tension``       | T_i = max_tension·(a_i + 1)/2 (N), absolute                          |
    | ``tension_delta`` | T_i ← clip(T_i + a_i·tension_step·max_tension, 0, max_tension) (N)   |
    | ``length_delta`` | l_i ← l_i + a_i·length_step (m), projected onto the lengths of an inextensible PCC shape, then scaled into the tension-reachable set. Backends with length control only (the analytic one). |
    | ``displacement`` | d_i = d_min + (a_i + 1)/2·(d_max − d_min) (m), absolute tendon displacement at the drive (``params.displacement_range``; positive = pulled in); the tendon pulls with T_i = clip(T0_i + k_i·(d_i − s_i), 0, max_tension) (SPEC §8). Every backend. |
    | ``displacement_delta`` | d_i ← clip(d_i + a_i·displacement_step, d_min, d_max) (m), then as ``displacement``. |

    In the displacement modes ``info`` adds ``displacements`` (C,) m, ``slack`` and
    ``saturated`` (C,) bool (T = 0, T = max_tension), and the observation appends the field
    ``displacements`` (C entries, the held d normalised to the range: −1 = d_min, +1 = d_max);
    CCKA solves the displacement statics, MuJoCo drives each tendon with a clamped spring
    actuator, pybullet integrates the law implicitly (``Backend.apply_displacements``).

    ## Observation Space
    A flat ``Box(float32)`` whose fields the task declares (an ``ObservationSpec``:
    ``env.unwrapped.observation_spec``; ``observation_spec.table()`` prints the index table).
    For reach on the paper robot (18 entries):

    | index | observation | min | max | unit |
    |-------|-------------|-----|-----|------|
    | 0–2 | tip position x, y, z in R0 | -0.641 | 0.641 | m |
    | 3–5 | goal position x, y, z in R0 | -0.641 | 0.641 | m |
    | 6–8 | goal − tip | -1.282 | 1.282 | m |
    | 9–11 | tanh((goal − tip) / 0.01 m) | -1 | 1 | – |
    | 12–14 | cable tensions / max_tension | 0 | 1 | – |
    | 15–17 | (cable length − L_i) / (π r_i m_i), L_i: backbone length the cable spans | -1 | 1 | – |

    Goal-conditioned (``GoalCDCREnv``, or ``goal_conditioned=True`` in ``gymnasium.make``): a
    ``Dict`` in the Gymnasium-Robotics convention — ``observation`` (the task's goal-free
    fields), ``achieved_goal``, ``desired_goal`` — with a ``compute_reward`` vectorised over
    leading dimensions, for HER.

    ## Rewards
    The task's (reach: dense −‖goal − tip‖ in m, or sparse). ``info`` always holds the task's
    entries (reach: ``distance`` m, ``is_success``, ``goal`` m) and the robot's: ``tip`` (3,) m,
    ``tensions`` (C,) N, ``cable_lengths`` (C,) m, as float64 arrays.

    ## Starting State
    ``initial_state="straight"`` (default): all tensions zero, the straight robot (or, on a
    backend with gravity, its rest shape). ``"random"``: a shape drawn like the goals and held
    by its minimal tensions. ``reset(options=...)`` accepts ``goal`` (the task's goal; reach:
    (3,) m, projected onto the reachable set) and ``initial_tensions`` ((C,) N in
    [0, max_tension]). In the displacement modes the drives then hold
    d = s + (T − T0)/k + c·Σ(T − T0) (c the robot's ``base_compliance``), the
    displacements whose law gives the reset tensions at the reset shape (straight: every
    tendon at its slack point, d = −T0/k), clipped to the range; ``initial_displacements``
    ((C,) m in the range) starts instead from the equilibrium under given displacements.

    ## Episode End
    No termination (reach: reach *and hold*) unless ``terminate_on_success=True``. Truncation
    after ``max_episode_steps`` (100 for the registered ids) by Gymnasium's ``TimeLimit``.

    ## Arguments
    ``gymnasium.make("cdcr_gym/CCKAReach-v0", **kwargs)`` passes the backend's arguments
    (``params``/``robot``, and for bullet ``gravity``, ``physics_timestep``, ...) to the backend,
    the task's (reach: ``reward_type``, ``distance_threshold``) to the task, and these to the env:

    | argument               | default           | effect                                           |
    |------------------------|-------------------|--------------------------------------------------|
    | ``backend``            | (required)        | the robot model, a ``Backend`` instance (N = 1)  |
    | ``task``               | ``Reach()``       | the task object                                  |
    | ``action_mode``        | ``tension_delta`` | see Action Space                                 |
    | ``tension_step``       | 0.05              | max tension change per step, fraction of T_max   |
    | ``length_step``        | 0.002             | max cable displacement per step (m)              |
    | ``displacement_step``  | 0.001             | max tendon displacement change per step (m), ``displacement_delta`` |
    | ``initial_state``      | ``straight``      | ``straight`` or ``random``                       |
    | ``terminate_on_success``| False            | end the episode once the task succeeds           |
    | ``render_mode``        | None              | ``rgb_array`` or ``human``                       |
    | ``render_width``       | 480               | image width (px)                                 |
    | ``render_height``      | 480               | image height (px)                                |
    | ``randomize`` | None | per-episode parameter ranges (domain randomisation, ``cdcr_gym.randomization``) |
    | ``imperfections`` | None | sensor noise/bias, action delay, tension rate limit, actuator noise (``cdcr_gym.randomization``) |
    | ``observe_tip_velocity`` | False | append ``tip_velocity`` (3, m/s): the tip's displacement over the last control step / the control timestep (0.02 s on CCKA), 0 after a reset |
    | ``safety_filter`` | False | Obstacle: correct commands whose CCKA-predicted shape would touch a sphere (``cdcr_gym.envs.safety``); ``info`` gains ``safety_filtered``, ``safety_correction`` |
    | ``safety_margin`` | 0.0 | clearance (m) the filter keeps |
    | ``safety_penalty`` | 0.0 | reward − penalty × ``safety_correction`` (‖T_safe − T_cmd‖ / T_max) |
    | ``drive_max_tension`` | None | displacement modes: the drives' tension cap (N; ``inf``: none; None: ``max_tension``); observed tensions saturate at their range |
    | ``drive_backlash`` | 0.0 | displacement modes: the play (m) between each drive's command and its tendon; ``info`` gains ``tendon_displacements`` |
    | ``drive_softening`` | 0.0 | displacement modes: the rate σ (1/m) at which the drives' pull saturates, tanh(σy)/σ for a drive at y > 0 (``cdcr_gym.model.drive_softening``); ``info`` gains ``tendon_displacements`` |

    ## Version History
    * v0: initial release (one-section reach); the n-section core keeps its layout and results.
    """

    #: Whether observations are the Gymnasium-Robotics Dict (set by :class:`GoalCDCREnv`).
    goal_conditioned = False

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 25}

    def __init__(
        self,
        backend: Backend,
        task: Task | None = None,
        *,
        render_mode: str | None = None,
        render_width: int = defaults.RENDER_SIZE,
        render_height: int = defaults.RENDER_SIZE,
        **options: Any,
    ) -> None:
        # options: the keyword arguments of EnvCore (the signature shown is built from it)
        if not isinstance(backend, Backend):
            raise ValueError(f"backend must be a cdcr_gym.backends.Backend, got {backend!r}")
        if backend.num_robots != 1:
            raise ValueError(f"backend must hold one robot, got num_robots={backend.num_robots}")
        if "goal_conditioned" in options:
            raise ValueError(
                "goal_conditioned is chosen by the class (GoalCDCREnv) or by gymnasium.make"
            )
        task = Reach() if task is None else task
        self.core = EnvCore(backend, task, goal_conditioned=self.goal_conditioned, **options)
        if render_mode is not None:
            validation.choice(render_mode, "render_mode", tuple(self.metadata["render_modes"]))
        if render_mode == "human":
            from cdcr_gym import rendering

            if not rendering.has_display():  # fail here, not at the first render
                backend.close()
                raise RuntimeError(
                    'render_mode="human" needs a display (DISPLAY or WAYLAND_DISPLAY is not '
                    'set); use render_mode="rgb_array" on a headless machine'
                )
        self.render_mode = render_mode
        self.render_width = validation.integer(render_width, "render_width", 16)
        self.render_height = validation.integer(render_height, "render_height", 16)
        self._action_shape = (self.params.n_cables,)
        self.action_space = self.core.action_space
        self.observation_space = self.core.observation_space

    # -- task API -------------------------------------------------------------------------------
    @property
    def goal(self) -> np.ndarray:
        """The current goal of the task (a copy)."""
        return self.task.desired_goal()[0].copy()

    # -- Gymnasium API --------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        _, initial_tensions, goal = self.core.reset_options(options)  # before the seeding
        super().reset(seed=seed)
        self.core.reset(_ONE, [self.np_random], initial_tensions, goal)
        obs, _, _, info = self._observe()
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        self.core.step(validation.clipped_action(action, self._action_shape)[None])
        obs, reward, terminated, info = self._observe()
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    def _observe(self) -> tuple[Any, ...]:
        """The core's outputs for its one env: (observation, reward, terminated, info)."""
        core = self.core
        obs, reward, success, info = core.observe()
        terminated = core.terminated(success)
        return one_env((obs, reward, terminated, info))

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        from cdcr_gym import rendering

        centres, rotations = self.backend.disk_frames(0)
        scene = dict(
            backbone_points=self.backend.backbone_points(0),
            disk_centres=centres,
            disk_rotations=rotations,
            params=self.params,
            tensions=self.core.readings.tensions[0],
            **self.task.render_markers(),
        )
        if self.render_mode == "rgb_array":
            return rendering.draw_scene(width=self.render_width, height=self.render_height, **scene)
        rendering.show_scene(**scene)
        return None

    def close(self) -> None:
        if self.render_mode == "human":
            from cdcr_gym import rendering

            rendering.close_window()
        self.backend.close()
        super().close()


class GoalCDCREnv(CDCREnv):
    """:class:`CDCREnv` with a Gymnasium-Robotics ``Dict`` observation, for HER.

    ``observation``: the task's goal-free fields; ``achieved_goal`` / ``desired_goal``: the
    task's goal vectors. The reward of every step equals
    ``compute_reward(obs["achieved_goal"], obs["desired_goal"], info)``. Same arguments as
    :class:`CDCREnv`.
    """

    goal_conditioned = True

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray | float:
        """Reward for ``achieved_goal`` and ``desired_goal`` (..., goal size), vectorised over
        leading dimensions (HER relabels batches): shape (...), or a float for one pair."""
        reward = self.task.compute_reward(achieved_goal, desired_goal, info)
        return float(reward) if np.ndim(reward) == 0 else reward


def _signature() -> inspect.Signature:
    """:class:`CDCREnv`'s signature as ``inspect`` shows it: ``backend``, ``task``, then
    :class:`EnvCore`'s options (their one source) and the rendering arguments."""
    own = inspect.signature(CDCREnv.__init__).parameters
    core = inspect.signature(EnvCore.__init__).parameters
    options = [
        p for name, p in core.items() if p.kind is p.KEYWORD_ONLY and name != "goal_conditioned"
    ]
    render = [own[name] for name in RENDER_KEYS]
    return inspect.Signature(
        [own["self"], own["backend"], own["task"], *options, *render], return_annotation=None
    )


CDCREnv.__init__.__signature__ = _signature()  # type: ignore[attr-defined]
