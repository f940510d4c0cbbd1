"""The env core: reset and step of N envs on one backend and one task, written once, batched.

Both Gymnasium faces use it: the single env (``cdcr_gym.envs.env``) runs it with N = 1, the
batched vector env (``cdcr_gym.envs.vector``) with N = num_envs. Order of a step:

1. the clipped actions (N, C) become cable commands (``Actuation``);
2. the backend holds them for one control step (``Backend.apply_tensions`` /
   ``apply_cable_lengths`` / ``apply_displacements``) and is read back (``Backend.read``);
3. the task moves on by one step (``Task.advance``: a moving target, a collision check);
4. the task fills the observation (``Task.observe``) and computes reward, success and its info
   entries (``Task.evaluate``); the core adds the robot's own entries (``tip``, ``tensions``,
   ``cable_lengths``) to ``info``.

Randomness: every env owns a generator (the single env's ``np_random``); at a reset the start
shape (``initial_state="random"``) and then the goal are drawn from it, in that order. Domain
randomisation and imperfections (``cdcr_gym.randomization``, off by default) draw from the same
generator: their episode draws come first at a reset, their per-step noise after the action.

Displacement action modes (``displacement``, ``displacement_delta``; SPEC §8): the env holds the
commanded tendon displacements d (N, C) m. A reset puts the robots at rest in the equilibrium
under tensions as in the tension modes (zero: straight; ``initial_state="random"``;
``initial_tensions``) and then sets the drives consistently: d = s + (T − T0)/k + c·Σ(T − T0),
the displacement whose law gives those tensions at that shape (s the backend's shortening, c the
robot's ``base_compliance``; at zero tension every tendon sits exactly at its slack point;
``model.tendons.holding_displacements``). With a ``drive_softening`` d is the pull, and the
command is the one whose pull it is. A start whose d leaves the range (softened) is not one the
drives hold: it is rested in the drives' equilibrium under the clipped d instead.
``options["initial_displacements"]`` instead starts from the drives' equilibrium under given
displacements (``Backend.reset_displacements``: their law with their own cap). ``info`` gains
``displacements`` (N, C) m, ``slack`` and ``saturated`` (N, C) bool (and, with a
``drive_backlash`` or a ``drive_softening``, ``tendon_displacements`` (N, C) m: the pulls that
reach the tendons through the play and the softening; ``drive_max_tension`` caps the drives);
the observation gains the
field ``displacements`` (the commanded d normalised to the range, [−1, 1]). Imperfections in
these modes: ``action_delay`` delays the action (a reset fills the queue with the action that
holds the reset displacements); sensor noise and biases act as in every mode; the actuator
imperfections of the tension modes (``actuator_noise``, ``tension_rate_limit``,
``tension_lag``, ``tension_response``) are refused (a position-controlled drive has none of
them; a physics backend's own dynamics and the drives' compliance do the settling). Goals keep
coming from the tension statics (``Backend.equilibrium``): a shape held by tensions T in
[0, max_tension] is held by the displacements d = s + (T − T0)/k + c·Σ(T − T0), so the reachable shapes are
the same wherever ``displacement_range`` covers the tendons' shortenings s — on the paper and
tdcr2 presets for every goal; on ``ftdcr_v4``, whose range is that of its recorded commands
(−10 … +12.5 mm), about a fifth of the goals need a shortening beyond +12.5 mm (by up to 8 mm)
and are approached, not reached.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.envs.actuation import Actuation
from cdcr_gym.envs.safety import SafetyFilter
from cdcr_gym.model.backlash import play_step
from cdcr_gym.model.drive_softening import check_rate, command_for_pull, soften
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.tendons import holding_displacements, tendon_tensions
from cdcr_gym.model.workspace import sample_tensions_each
from cdcr_gym.randomization import INFO_PREFIX, DomainRandomization, Imperfections
from cdcr_gym.tasks.base import Task
from cdcr_gym.tasks.observation import Field, ObservationSpec

__all__ = ["EnvCore", "CoreAttributes", "INITIAL_STATES", "OPTION_KEYS"]

#: Start shapes: straight (zero tensions) or a shape drawn like the goals.
INITIAL_STATES = defaults.INITIAL_STATES
#: Keys of ``reset(options=...)`` (the vector env also takes Gymnasium's ``reset_mask``).
OPTION_KEYS = ("goal", "initial_tensions", "initial_displacements")


class EnvCore:
    """N envs of one task on one backend (N = ``backend.num_robots``), and their spaces
    (:attr:`action_space`, :attr:`observation_space` of one env; :attr:`spec` the flat layout).

    Args:
        backend: the robots (its ``num_robots`` sets N).
        task: the task (bound to the robot and N here).
        action_mode, tension_step, length_step, displacement_step: see
            :class:`~cdcr_gym.envs.actuation.Actuation` (displacement modes: module docstring).
        initial_state: ``"straight"`` or ``"random"``, or a sequence of N such values.
        goal_conditioned: Dict observations (``observation``, ``achieved_goal``,
            ``desired_goal``) instead of a flat vector.
        terminate_on_success: end an env's episode once its task succeeds.
        randomize: per-episode parameter ranges (``cdcr_gym.randomization``); None: off.
        imperfections: sensor and actuator imperfections (``cdcr_gym.randomization``);
            None: off.
        observe_tip_velocity: append the field ``tip_velocity`` (3, m/s) to the task's
            observation: the tip's displacement over the last control step divided by the
            backend's control timestep (``defaults.NOMINAL_TIMESTEP`` on a quasi-static
            backend), 0 after a reset. A physics robot moves on after a command (it overshoots
            and settles); this tells a policy how. From the backend's readings (the
            ``imperfections`` noise acts on the task's fields, not on this difference).
        safety_filter: correct every tension command whose CCKA-predicted shape would come
            closer than ``safety_margin`` to an obstacle (``cdcr_gym.envs.safety``: a
            control-barrier projection; exact on the frictionless analytic backend, a model
            prediction on physics). Tasks with obstacles only, tension action modes only.
            ``info`` gains ``safety_filtered`` (the command was changed) and
            ``safety_correction`` (‖T_safe − T_cmd‖ / max_tension).
        safety_margin: the clearance (m, >= 0) the filter keeps.
        safety_penalty: reward subtracted per unit of ``safety_correction`` (>= 0; 0: none):
            lets a policy learn to need the filter less.
        drive_max_tension: the displacement drives' tension cap (N, > 0; ``inf``: none; None:
            the robot's ``max_tension``, the range of tension actions;
            ``Backend.set_drive_max_tension``). Displacement action modes only. Above
            ``max_tension`` the observed tensions saturate at their range (``info`` has the
            true ones). The goals held by the drives and a reset's ``initial_displacements``
            equilibrium are the drives' equilibria under this cap.
        drive_backlash: the play w (m, >= 0) between each drive's command and its tendon
            (``cdcr_gym.model.backlash``): every step the tendon takes y = clip(y, d − w/2,
            d + w/2) of the commanded d; a reset sets y = d. Displacement action modes only.
        drive_softening: the rate σ (1/m, >= 0; 0: none) at which the drives' pull saturates
            (``cdcr_gym.model.drive_softening``): a drive at y > 0 (after its play) pulls its
            tendon by tanh(σy)/σ. Displacement action modes only. The goals the drives hold lie
            within the softened range, and a reset commands the displacements whose pulls hold
            its shape.
            A calibrated robot's cap, backlash and softening: ``twin_kwargs_from_yaml``
            (``cdcr_gym.calibration``).
    """

    def __init__(
        self,
        backend: Backend,
        task: Task,
        *,
        action_mode: str = defaults.ACTION_MODE,
        tension_step: float = defaults.TENSION_STEP,
        length_step: float = defaults.LENGTH_STEP,
        displacement_step: float = defaults.DISPLACEMENT_STEP,
        initial_state: str | Sequence[str] = defaults.INITIAL_STATE,
        goal_conditioned: bool = False,
        terminate_on_success: bool = False,
        randomize: Mapping[str, Any] | None = None,
        imperfections: Mapping[str, Any] | None = None,
        observe_tip_velocity: bool = False,
        safety_filter: bool = False,
        safety_margin: float = 0.0,
        safety_penalty: float = 0.0,
        drive_max_tension: float | None = None,
        drive_backlash: float = 0.0,
        drive_softening: float = 0.0,
    ) -> None:
        if not isinstance(backend, Backend):
            raise ValueError(f"backend must be a cdcr_gym.backends.Backend, got {backend!r}")
        if not isinstance(task, Task):
            raise ValueError(f"task must be a cdcr_gym.tasks.Task, got {task!r}")
        actuation = Actuation(
            action_mode, backend.params, tension_step, length_step, displacement_step
        )
        if actuation.commands_lengths and not backend.supports_length_control:
            raise ValueError(
                f"action_mode='length_delta' needs a backend with cable-length control; "
                f"{type(backend).__name__} has none (use 'tension' or 'tension_delta')"
            )
        if actuation.commands_displacements:
            if not backend.supports_displacement_control:
                raise ValueError(
                    f"action_mode={action_mode!r} needs a backend with displacement control; "
                    f"{type(backend).__name__} has none"
                )
            backend.enable_displacement_control()
        self.goal_conditioned = validation.flag(goal_conditioned, "goal_conditioned")
        self.terminate_on_success = validation.flag(terminate_on_success, "terminate_on_success")
        if self.goal_conditioned and task.goal_size == 0:
            raise ValueError(f"goal_conditioned=True: the {type(task).__name__} task has no goal")
        self.backend = backend
        self.params = backend.params
        self.num_envs = n = backend.num_robots
        self.n_cables = backend.n_cables
        self.task = task
        self.actuation = actuation
        task.bind(self.params, n)
        #: the drives' softening rate σ (1/m; ``cdcr_gym.model.drive_softening``)
        self.drive_softening = check_rate(drive_softening)
        if actuation.commands_displacements:  # goals the drives can hold
            low, high = actuation.displacement_range
            task.goal_displacement_range = (low, float(soften(high, self.drive_softening)))
        states = [initial_state] * n if isinstance(initial_state, str) else list(initial_state)
        if len(states) != n:
            raise ValueError(
                f"initial_state must be one value or a sequence of {n} values, got {len(states)}"
            )
        for s in states:
            validation.choice(s, "initial_state", INITIAL_STATES)
        self.initial_states = tuple(states)
        self._random_start = np.array([s == "random" for s in states])
        self.spec = task.observation_spec(self.goal_conditioned)
        #: Rows of the task's own fields in the observation (the env's fields follow them).
        self._task_rows = self.spec.size
        n_c = backend.n_cables
        self._held_displacements = np.zeros((n, n_c))
        self._drive_flags = (np.zeros((n, n_c), dtype=bool), np.zeros((n, n_c), dtype=bool))
        if actuation.commands_displacements:
            low, high = actuation.displacement_range
            field = Field.uniform(
                "displacements",
                n_c,
                -1.0,
                1.0,
                "1",
                f"commanded tendon displacements, normalised: -1 = d_min ({low} m), "
                f"+1 = d_max ({high} m)",
                tuple(f"d{i + 1}" for i in range(n_c)),
            )
            self.spec = ObservationSpec([*self.spec.fields, field])
        #: Rows of the task's fields and the displacement field (the velocity field follows).
        self._env_rows = self.spec.size
        self.observe_tip_velocity = validation.flag(observe_tip_velocity, "observe_tip_velocity")
        dt = float(backend.control_timestep)
        self._inv_timestep = 1.0 / (dt if dt > 0.0 else defaults.NOMINAL_TIMESTEP)
        self._tip_velocity = np.zeros((3, n))  # field-major rows, m/s
        if self.observe_tip_velocity:
            bound = 2.0 * self.params.length * self._inv_timestep  # no step moves the tip > 2l
            velocity = Field.uniform(
                "tip_velocity",
                3,
                -bound,
                bound,
                "m/s",
                "tip velocity over the last control step",
                ("x", "y", "z"),
            )
            self.spec = ObservationSpec([*self.spec.fields, velocity])
        c = self.n_cables
        self.action_space = spaces.Box(-1.0, 1.0, shape=(c,), dtype=np.float32)
        if self.goal_conditioned:
            goal = task.goal_space()
            self.observation_space: spaces.Space = spaces.Dict(
                {
                    "observation": self.spec.box(),
                    "achieved_goal": goal,
                    "desired_goal": goal,
                }
            )
        else:
            self.observation_space = self.spec.box()
        #: ``options["initial_displacements"]`` of the reset under way (:meth:`reset_options`).
        self.pending_displacements: Any = None
        self._readings = backend.read()
        self._held_tensions = self._readings.tensions
        self._held_lengths = self._readings.cable_lengths
        self._init_realism(randomize, imperfections)
        self._init_safety(safety_filter, safety_margin, safety_penalty)
        self._init_drives(drive_max_tension, drive_backlash)

    def _init_drives(self, max_tension: float | None, backlash: float) -> None:
        """The displacement drives' cap (on the backend) and backlash (:attr:`drive_backlash` m,
        and the drives' displacements y (N, C) m behind it)."""
        self.drive_backlash = validation.positive(
            backlash, "drive_backlash", allow_zero=True, unit="m"
        )
        if not self.actuation.commands_displacements and (
            max_tension is not None or self.drive_backlash or self.drive_softening
        ):
            raise ValueError(
                f"drive_max_tension={max_tension!r}, drive_backlash={backlash!r} and "
                f"drive_softening={self.drive_softening!r} need a displacement action mode "
                f"('displacement' or 'displacement_delta'), got "
                f"action_mode={self.actuation.mode!r}"
            )
        if max_tension is not None:
            try:
                self.backend.set_drive_max_tension(max_tension)
            except ValueError:
                raise ValueError(
                    f"drive_max_tension must be a number > 0 N (inf: no cap), got {max_tension!r}"
                ) from None
        #: drives that pull beyond max_tension: the observed tensions saturate at their range
        self._saturating_sensors = self.backend.drive_max_tension > self.params.max_tension
        #: the drives' displacements y (N, C) m behind their backlash (before the softening)
        self._tendon_displacements = self._held_displacements.copy()

    def _init_safety(self, enabled: bool, margin: float, penalty: float) -> None:
        """The safety filter (None when off) and its per-env correction (N,)."""
        enabled = validation.flag(enabled, "safety_filter")
        margin = validation.positive(margin, "safety_margin", allow_zero=True)
        self.safety_penalty = validation.positive(penalty, "safety_penalty", allow_zero=True)
        self.safety: SafetyFilter | None = None
        self.safety_correction = np.zeros(self.num_envs)
        if not enabled:
            if self.safety_penalty or margin:
                raise ValueError(
                    f"safety_margin={margin!r} and safety_penalty={penalty!r} need "
                    f"safety_filter=True"
                )
            return
        if not self.task.has_obstacles:
            raise ValueError(
                f"safety_filter=True needs a task with obstacles (Obstacle); "
                f"{type(self.task).__name__} has none"
            )
        act = self.actuation
        if act.commands_lengths or act.commands_displacements:
            raise ValueError(
                "safety_filter=True needs a tension action mode ('tension' or "
                f"'tension_delta'), got action_mode={act.mode!r}"
            )
        step = None if act.mode == "tension" else act.tension_step * act.max_tension
        self.safety = SafetyFilter(self.task.model_clearance, act.max_tension, step, margin)

    def _init_realism(
        self, randomize: Mapping[str, Any] | None, imperfections: Mapping[str, Any] | None
    ) -> None:
        """Domain randomisation and imperfections: None each when off (the plain path)."""
        n, act = self.num_envs, self.actuation
        dr = DomainRandomization(randomize, self.params, self.backend)
        imp = Imperfections(
            imperfections,
            self.params,
            n,
            commands_tensions=not (act.commands_lengths or act.commands_displacements),
            absolute_tensions=act.mode == "tension",
        )
        self.randomization = dr if dr.enabled else None
        self.imperfections = imp if imp.enabled else None
        self.randomized = {name: np.full(n, np.nan) for name in dr.reported}
        self._rngs: list[np.random.Generator | None] = [None] * n
        box = self.spec.box()
        task_rows = slice(0, self._task_rows)  # what the sensor noise acts on
        self._obs_bounds = (box.low[task_rows, None], box.high[task_rows, None])
        self._buffer_shape = (self.spec.size, n)

    def _draw_episode(self, idx: np.ndarray, rngs: list[np.random.Generator]) -> None:
        """Episode draws of envs ``idx``: randomised parameters (given to the backend), then
        the sensor biases."""
        for i, rng in zip(idx.tolist(), rngs):
            self._rngs[i] = rng
        dr = self.randomization
        if dr is not None:
            draws = [dr.sample(rng) for rng in rngs]
            values = {k: np.array([d[k] for d in draws]) for k in dr.reported}
            for k, v in values.items():
                self.randomized[k][idx] = v
            self.backend.set_randomized(idx, values)
        if self.imperfections is not None:
            self.imperfections.draw_biases(idx, rngs)

    # -- reset ----------------------------------------------------------------------------------
    def reset_options(
        self, options: Any, allow_mask: bool = False
    ) -> tuple[np.ndarray | None, Any, Any]:
        """``reset(options=...)`` of either env, checked: (the envs to reset (sorted indices)
        from ``reset_mask`` or None for all, ``initial_tensions``, ``goal``); an
        ``initial_displacements`` option is kept for :meth:`reset` (:attr:`pending_displacements`).

        Every option is validated here, before the caller seeds or draws anything.

        Raises:
            ValueError: naming ``options`` for anything but None or a mapping of
                :data:`OPTION_KEYS` (and ``reset_mask`` with ``allow_mask``), naming
                ``options['reset_mask']`` for a mask that is not (N,) bool selecting an env,
                ``options['initial_tensions']`` and ``options['goal']`` (``Task.check_goal``)
                for a bad shape or value.
        """
        self.pending_displacements = None
        if options is None:
            return None, None, None
        allowed = OPTION_KEYS + (("reset_mask",) if allow_mask else ())
        if not isinstance(options, Mapping):
            raise ValueError(f"options must be None or a dict with keys {allowed}, got {options!r}")
        unknown = set(options) - set(allowed)
        if unknown:
            raise ValueError(
                f"options has unknown keys {sorted(unknown, key=str)}; allowed: "
                + ", ".join(repr(k) for k in allowed)
            )
        mask = options.get("reset_mask")
        idx = None
        if mask is not None:
            n = self.num_envs
            if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(
                    f"options['reset_mask'] must be a bool numpy array of shape ({n},), "
                    f"got {mask!r}"
                )
            if not mask.any():
                raise ValueError("options['reset_mask'] must select at least one env")
            idx = np.flatnonzero(mask)
        displacements = options.get("initial_displacements")
        if displacements is not None:
            if not self.actuation.commands_displacements:
                raise ValueError(
                    "options['initial_displacements'] needs a displacement action mode "
                    f"('displacement' or 'displacement_delta'), got {self.actuation.mode!r}"
                )
            if options.get("initial_tensions") is not None:
                raise ValueError(
                    "give options['initial_tensions'] or options['initial_displacements'], not both"
                )
        m = self.num_envs if idx is None else idx.size
        tensions, goal = self._check_values(m, options.get("initial_tensions"), options.get("goal"))
        if displacements is not None:
            displacements = self._check_displacements(m, displacements)
        self.pending_displacements = displacements
        return idx, tensions, goal

    def _check_values(self, m: int, initial_tensions: Any, goal: Any) -> tuple[Any, Any]:
        """``initial_tensions`` as (m, C) N and ``goal`` as the task's (m, ·) (or None each),
        validated before a reset draws or changes anything: a refused reset leaves the env as
        it was (state, parameters, generator)."""
        c = self.n_cables
        tensions = None
        if initial_tensions is not None:
            tensions = validation.per_cable(
                initial_tensions, "options['initial_tensions']", c, 0.0, self.params.max_tension
            )
            if tensions.shape not in ((c,), (m, c)):
                raise ValueError(
                    f"options['initial_tensions'] must have shape ({c},) or "
                    f"({m}, {c}), got shape {tensions.shape}"
                )
            tensions = np.broadcast_to(tensions, (m, c))
        if goal is not None:
            goal = self.task.check_goal(goal, m)
        return tensions, goal

    def _check_displacements(self, m: int, displacements: Any) -> np.ndarray:
        """``initial_displacements`` as (m, C) m inside the robot's ``displacement_range``."""
        c = self.n_cables
        low, high = self.actuation.displacement_range
        d = validation.per_cable(displacements, "options['initial_displacements']", c, low, high)
        if d.shape not in ((c,), (m, c)):
            raise ValueError(
                f"options['initial_displacements'] must have shape ({c},) or ({m}, {c}), "
                f"got shape {d.shape}"
            )
        return np.array(np.broadcast_to(d, (m, c)))

    def reset(
        self,
        idx: np.ndarray,
        rngs: list[np.random.Generator],
        initial_tensions: Any = None,
        goal: Any = None,
    ) -> None:
        """Reset envs ``idx`` (sorted indices), drawing from ``rngs`` (one generator per env).

        ``initial_tensions`` ((C,) or (len(idx), C) N) and ``goal`` (task goal, one or one per
        env) override the draws.
        """
        m, c = idx.size, self.n_cables
        given, goal = self._check_values(m, initial_tensions, goal)  # before any draw
        displacements = getattr(self, "pending_displacements", None)
        self.pending_displacements = None
        if displacements is not None:
            displacements = self._check_displacements(m, displacements)
        if self.randomization is not None or self.imperfections is not None:
            self._draw_episode(idx, rngs)
        if given is not None:
            tensions = given
        else:
            tensions = np.zeros((m, c))
            random = self._random_start[idx] & (displacements is None)
            if random.any():
                tensions[random] = sample_tensions_each(
                    [r for r, k in zip(rngs, random) if k], self.params
                )
        mask = None
        if m != self.num_envs:
            mask = np.zeros(self.num_envs, dtype=bool)
            mask[idx] = True
        full = np.zeros((self.num_envs, c))
        if displacements is not None:  # the drives' equilibrium on this episode's robot
            full[idx] = displacements
            self.backend.reset_displacements(soften(full, self.drive_softening), mask)
        else:
            full[idx] = tensions
            self.backend.reset(full, mask)
            if self.actuation.commands_displacements:
                displacements = self._holding_commands(idx)
        self.task.reset_goals(idx, rngs, self.backend, goal)
        r = self._readings = self.backend.read()
        if m == self.num_envs:
            self._held_tensions = r.tensions.copy(order="K")
            self._held_lengths = r.cable_lengths.copy(order="K")
        else:
            self._held_tensions = self._held_tensions.copy(order="K")
            self._held_lengths = self._held_lengths.copy(order="K")
            self._held_tensions[idx] = r.tensions[idx]
            self._held_lengths[idx] = r.cable_lengths[idx]
        if displacements is not None:  # (set in every displacement action mode)
            self._reset_drives(idx, displacements)
        if self.imperfections is not None:
            self.imperfections.reset(idx, r.tensions[idx])
            if self.imperfections.delay and self.actuation.mode == "displacement":
                hold = self.actuation.normalized(self._held_displacements[idx])
                self.imperfections.queue[idx] = hold[:, None, :]
        self._tip_velocity[:, idx] = 0.0
        if self.safety is not None:
            self.safety_correction[idx] = 0.0

    def _holding_commands(self, idx: np.ndarray) -> np.ndarray:
        """The commands (len(idx), C) m that hold envs ``idx`` at the shape and tensions they
        were reset to (module docstring). A shape whose pulls leave the drives' (softened)
        range is not one the drives hold: those envs are rested in the drives' equilibrium
        under the clipped pulls instead (``Backend.reset_displacements``)."""
        r = self.backend.read()
        p = self.params
        low, high = self.actuation.displacement_range
        holding = holding_displacements(
            self.backend.straight_cable_lengths - r.cable_lengths[idx],
            r.tensions[idx],
            p.cable_stiffness,
            p.cable_pretension,
            p.base_compliance,
        )
        pulls = np.clip(holding, low, float(soften(high, self.drive_softening)))
        clipped = np.any(pulls != holding, axis=1)
        if clipped.any():
            full = np.zeros((self.num_envs, self.n_cables))
            full[idx[clipped]] = pulls[clipped]
            mask = np.zeros(self.num_envs, dtype=bool)
            mask[idx[clipped]] = True
            self.backend.reset_displacements(full, mask)
        return command_for_pull(pulls, self.drive_softening)

    def _reset_drives(self, idx: np.ndarray, displacements: np.ndarray) -> None:
        """The drives of envs ``idx`` after a reset (module docstring) at the commands
        ``displacements`` (len(idx), C) m."""
        r = self._readings
        held = self._held_displacements.copy()
        held[idx] = displacements
        self._held_displacements = held
        tendon = self._tendon_displacements.copy()
        tendon[idx] = displacements  # the drives' play centred: no offset after a reset
        self._tendon_displacements = tendon
        tensions = r.tensions[idx]
        slack, saturated = (f.copy() for f in self._drive_flags)
        slack[idx] = tensions <= 0.0
        saturated[idx] = tensions >= self.backend.drive_max_tension
        self._drive_flags = (slack, saturated)

    def _step_displacements(self, action: np.ndarray) -> None:
        """One control step of a displacement action mode."""
        act = self.actuation
        d = act.displacements(action, self._held_displacements)
        self._held_displacements = d
        if self.drive_backlash:
            d = play_step(self._tendon_displacements, d, self.drive_backlash)
        self._tendon_displacements = d
        d = soften(d, self.drive_softening)
        self.backend.apply_displacements(d)
        self._readings = self.backend.read()
        state = self.backend.drive_state
        if state is not None:
            self._drive_flags = (state.slack, state.saturated)
        else:  # a backend that reports none: from the law at the read shape
            p = self.params
            shortening = self.backend.straight_cable_lengths - self._readings.cable_lengths
            _, slack, saturated = tendon_tensions(
                d,
                shortening,
                p.cable_stiffness,
                p.cable_pretension,
                self.backend.drive_max_tension,
                p.base_compliance,
            )
            self._drive_flags = (slack, saturated)

    # -- step -----------------------------------------------------------------------------------
    def step(self, action: np.ndarray, active: np.ndarray | None = None) -> None:
        """Apply clipped, finite actions (N, C) in [−1, 1] for one control step.

        ``active`` (N,) bool: the envs whose step counts (the others are reset right after and
        draw no actuator noise; None: all).
        """
        act = self.actuation
        imp = self.imperfections
        if self.observe_tip_velocity:
            self._previous_tip = self._readings.tip
        if imp is not None:
            action = imp.delayed(action)
        if act.commands_displacements:
            self._step_displacements(action)
        elif act.commands_lengths:
            self._held_lengths = act.lengths(action, self._held_lengths)
            self.backend.apply_cable_lengths(self._held_lengths)
            self._readings = self.backend.read()
        else:
            commanded = act.tensions(action, self._held_tensions)
            if self.safety is not None:
                measured = self.task.measured_clearance()  # after the last step or reset
                safe, _ = self.safety(commanded, self._held_tensions, measured)
                diff = safe - commanded
                self.safety_correction = np.sqrt(np.sum(diff * diff, axis=1)) / act.max_tension
                commanded = safe
            self._held_tensions = commanded
            if imp is not None and imp.actuates:
                shape, actuator = imp.actuate(self._held_tensions, self._rngs, active)
                self.backend.apply_tensions(shape)
                self._readings = self.backend.read()._replace(tensions=actuator)
            else:
                self.backend.apply_tensions(self._held_tensions)
                self._readings = self.backend.read()
        if self.observe_tip_velocity:  # from the readings before and after the step
            diff = self._readings.tip - self._previous_tip
            np.multiply(diff.T, self._inv_timestep, out=self._tip_velocity)
        self.task.advance(self.backend, self._readings)

    def terminated(self, success: np.ndarray) -> np.ndarray:
        """(N,) bool: the envs whose episode ends now: a success with ``terminate_on_success``,
        or the task's own end (``Task.terminal``, e.g. a collision). A fresh array."""
        if self.terminate_on_success:
            return success | self.task.terminal()
        return self.task.terminal().copy()

    @property
    def readings(self) -> Readings:
        """The backend's readings after the last reset or step."""
        return self._readings

    # -- outputs --------------------------------------------------------------------------------
    def observe(self) -> tuple[Any, np.ndarray, np.ndarray, dict[str, Any]]:
        """(observation, reward (N,), success (N,), info) of the current state, batched.

        The observation is an (N, size) float32 array (the transpose of a field-major buffer),
        or the Dict of (N, ·) float32 arrays.
        ``info`` holds the task's entries plus ``tip`` (N, 3) m, ``tensions`` (N, C) N and
        ``cable_lengths`` (N, C) m.
        """
        r = self._readings
        task = self.task
        buffer = np.empty(self._buffer_shape, dtype=np.float32)
        imp = self.imperfections
        rows = buffer[: self._task_rows]
        if imp is None:
            task.observe(r, rows, self.goal_conditioned)
            if self._saturating_sensors:  # tensions beyond the observed range
                np.clip(rows, self._obs_bounds[0], self._obs_bounds[1], out=rows)
        else:  # noisy readings; a sensor saturates at the observation space's bounds
            task.observe(imp.sense(r, self._rngs), rows, self.goal_conditioned)
            np.clip(rows, self._obs_bounds[0], self._obs_bounds[1], out=rows)
        if self.actuation.commands_displacements:
            buffer[self._task_rows : self._env_rows] = self.actuation.normalized(
                self._held_displacements
            ).T
        if self.observe_tip_velocity:  # within its bounds: no step moves the tip by 2l
            buffer[self._env_rows :] = self._tip_velocity
        flat = buffer.T  # (N, size), Fortran-ordered (like Gymnasium's CartPoleVectorEnv)
        obs: Any
        reward, success, info = task.evaluate(r)
        if self.goal_conditioned:
            obs = {
                "observation": flat,
                "achieved_goal": task.achieved_goal(r).astype(np.float32),
                "desired_goal": task.desired_goal().astype(np.float32),
            }
            # from the observed float32 goals, so that reward == compute_reward(obs goals)
            reward = task.compute_reward(obs["achieved_goal"], obs["desired_goal"])
        else:
            obs = flat
        info["tip"] = r.tip
        info["tensions"] = r.tensions
        info["cable_lengths"] = r.cable_lengths
        if r.anchor_tensions is not None:  # a backend with cable friction
            info["anchor_tensions"] = r.anchor_tensions
        if self.actuation.commands_displacements:
            info["displacements"] = self._held_displacements.copy()
            if self.drive_backlash or self.drive_softening:
                # a copy: without softening soften() hands back the env's own array
                info["tendon_displacements"] = soften(
                    self._tendon_displacements.copy(), self.drive_softening
                )
            info["slack"] = self._drive_flags[0].copy()
            info["saturated"] = self._drive_flags[1].copy()
        if self.randomized:
            for name, values in self.randomized.items():
                info[INFO_PREFIX + name] = values.copy()
        if self.safety is not None:  # (a task with obstacles: not goal-conditioned)
            info["safety_filtered"] = self.safety_correction > 0.0
            info["safety_correction"] = self.safety_correction.copy()
            reward = reward - self.safety_penalty * self.safety_correction
        return obs, reward, success, info


class CoreAttributes:
    """What both Gymnasium faces (the single env and the vector env) read from their core,
    written once: the robot, the task and the env's settings (read-only)."""

    core: EnvCore

    @property
    def params(self) -> RobotParams:
        """The robot (``backend.params``)."""
        return self.core.params

    @property
    def backend(self) -> Backend:
        """The robot model (N = 1 for the single env)."""
        return self.core.backend

    @property
    def task(self) -> Task:
        """The task object."""
        return self.core.task

    @property
    def observation_spec(self) -> ObservationSpec:
        """The flat observation's layout (``observation_spec.table()`` prints it)."""
        return self.core.spec

    @property
    def action_mode(self) -> str:
        """``tension``, ``tension_delta``, ``length_delta``, ``displacement`` or
        ``displacement_delta``."""
        return self.core.actuation.mode

    @property
    def tension_step(self) -> float:
        """Largest tension change per step (fraction of max_tension)."""
        return self.core.actuation.tension_step

    @property
    def length_step(self) -> float:
        """Largest cable displacement per step (m)."""
        return self.core.actuation.length_step

    @property
    def displacement_step(self) -> float:
        """Largest tendon displacement change per step in ``displacement_delta`` mode (m)."""
        return self.core.actuation.displacement_step

    @property
    def drive_softening(self) -> float:
        """The displacement drives' softening rate σ (1/m; 0: none;
        ``cdcr_gym.model.drive_softening``)."""
        return self.core.drive_softening

    @property
    def terminate_on_success(self) -> bool:
        """Whether an episode ends once the task succeeds."""
        return self.core.terminate_on_success

    @property
    def initial_state(self) -> str | tuple[str, ...]:
        """The start shape (``straight`` or ``random``), or one per env where they differ."""
        states = self.core.initial_states
        return states[0] if len(set(states)) == 1 else states

    def set_difficulty(self, difficulty: float) -> None:
        """The task's curriculum: episodes from the next reset on are drawn at ``difficulty``
        in (0, 1] (``Task.set_difficulty``, for every env; ``ValueError`` for a task without
        one)."""
        self.core.task.set_difficulty(difficulty)
