"""The inverse-kinematics controller: the reach oracle that learned policies are judged against.

A small policy object (observation in, action out) that knows the robot model. It reads the
observation by field name through the env's ``ObservationSpec`` and runs in one of two modes:

* **Open loop** (``feedback=False``, the default): it solves the inverse kinematics of the goal
  (``cdcr_gym.model.ik.solve_ik``: closed form for one section, numerical for several), takes
  the minimal tensions (or the cable lengths) of that shape, and commands them from the current
  state. On the analytic backend it reaches every reachable goal exactly (one step with absolute
  tensions; within the episode with increments). On another backend (pybullet, gravity, discrete
  disks) it commands what the model says and does not correct: centimetres of error remain.
* **Closed loop** (``feedback=True``): resolved-rate correction from the *measured* tip. Every
  step it takes the shape the held command stands for on the model (w = the bending of the held
  tensions, or of the held cable lengths in ``length_delta`` mode), the model Jacobian
  J = ∂f/∂w of the task's goal features f (the tip; for Pose the tip and ℓ·tip direction), and
  the error e between the goal's and the measured features, and commands

      w_cmd = s·(w + J⁺·(ff + gain·e)),   J⁺ = (JᵀJ + λI)⁻¹Jᵀ (damped least squares),

  with s <= 1 the factor that keeps the shape within the tension limits
  (``statics.reachable_scale``: no wind-up against them) and ``ff`` the goal's motion over the
  step (Track; zero for fixed goals). The commands are the model's minimal tensions of ``w_cmd``
  (so within [0, max_tension]) or its cable lengths, sent in the env's action mode as the
  open-loop commands are (increments scaled so the largest is one step). The held command is
  the integrator, so the law is stateless (any batch, any episode boundary) and its fixed point
  is e = 0 wherever the robot really ends up for a command: gravity, discrete disks, friction
  only change how many steps it takes.

  Far from the goal *on the model* — a model feature error |f(w) − goal| above
  ``ANCHOR_FRACTION``·ℓ = ℓ (ℓ the robot's length), more than the model–physics mismatch at the
  solution (≤ 0.69ℓ on bullet tdcr2 with gravity) — ``w_cmd`` is blended towards the model's
  IK solution of the goal (fully at 2ℓ); below, the law is pure feedback and its fixed point
  unchanged. From a straight start the local law alone settles in a wrong branch of a redundant
  robot (tdcr2 poses: 75 % success on bullet without the blend, 100 % with it, 20 episodes),
  and the model's global IK knows the branch.

  A known limit of this law on robots of several sections: where the command meets the tension
  limits, s < 1 scales the *whole* shape back towards straight, and that can balance the
  correction step — a fixed point away from the goal (FTDCR v4 CCKA twin, ``tension_delta``,
  25 goals per start: 56 % from straight, 60 % from random starts within 5 mm, the others
  ≈ 190 mm off; ``experiments.oracle_feedback``). The displacement modes below do not use it.

  ``gain`` is a pure integrator's gain per control step. The physics robot answers a step
  command in ≈ 0.3 s (15 steps of 0.02 s, paper robot on bullet), overshoots and settles by
  ≈ 0.6 s, which bounds it. On bullet with gravity (gain sweep in ``docs/tasks.md``): 0.05
  converges without overshoot but slowly (Track: the approach is not over when the 25-step
  settling window ends), 0.08 (the default) reaches Reach goals to < 0.02 mm and Pose goals to
  < 0.5 mm, 0.12 rings and 0.2 oscillates through much of an episode. On the quasi-static
  analytic backend the same law converges geometrically (1 − gain per step); there the
  open-loop mode is exact.

In the displacement action modes (``displacement``, ``displacement_delta``) the reach oracle
works on the drives themselves (:data:`AnalyticIKController.DRIVE_IK`; the Track and Pose
oracles turn their tension/shape targets into d = s(w) + (T − T0)/k, s the model's shortening
of w, k and T0 the robot's drives, a cable with T = 0 at its slack point). The minimal tensions
of the IK shape are not always within the drives' reach: on a robot with pretensioned,
compliant drives (FTDCR v4) a slack cable's slack point can lie below the range, the clipped
command pulls it taut and the tip misses by centimetres. So:

* open loop: the displacements within ``displacement_range`` whose model equilibrium puts the
  tip at the goal (:func:`cdcr_gym.model.ik.solve_displacement_ik`, cached per goal);
* closed loop: the same IK for the goal shifted by the model's error at the held command,
  ``goal + (f(d_held) − tip_measured)`` (f the model's tip of the held displacements' quasi-static
  equilibrium), started from the goal's own solution (so every step's target stays on one
  branch) and from the held displacements. Its fixed point is tip_measured = goal wherever the plant settles for a
  command; where model and plant agree (the CCKA backend) it is the open-loop solution, exact.
  ``gain`` is not used in these modes: the drives move at most ``displacement_step`` per step
  (``displacement_delta``), which paces the loop.

Either target is commanded absolutely (normalised to the range) or in increments from the held
displacements (the observation's ``displacements`` field), scaled so the largest is one step.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.envs.actuation import ACTION_MODES
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.drive_softening import check_rate, command_for_pull, soften
from cdcr_gym.model.ik import solve_displacement_ik, solve_ik
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import minimal_tensions, reachable_scale
from cdcr_gym.model.tendons import solve_displacement_statics
from cdcr_gym.tasks.observation import ObservationSpec

__all__ = ["AnalyticIKController", "FEEDBACK_GAIN"]

#: Default integrator gain (per control step) of the closed-loop mode.
FEEDBACK_GAIN = 0.08
#: Beyond ANCHOR_FRACTION·ℓ of feature error the closed loop blends towards the model's IK solution
#: (fully at twice that); below, it is pure feedback.
ANCHOR_FRACTION = 1.0
_JACOBIAN_STEP = 1e-6  # rad, central differences of the model features in w
_DAMPING = 1e-6  # λ of the damped least squares, relative to the mean of diag(JᵀJ)
_CACHE_SIZE = 256  # goals whose drive-IK solution is kept (open loop, and the closed loop's start)


class AnalyticIKController:
    """Inverse kinematics as a policy for a reach env (flat or goal-conditioned).

    Args:
        params: the robot the IK assumes.
        spec: the env's observation layout (flat, or the ``observation`` part of the Dict); the
            controller reads ``goal`` (flat only), ``tip`` (closed loop), ``tensions`` and
            ``cable_lengths`` from it.
        action_mode: the env's action mode (``tension``, ``tension_delta``, ``length_delta``,
            ``displacement``, ``displacement_delta``).
        tension_step: the env's ``tension_step`` (fraction of max_tension per step).
        length_step: the env's ``length_step`` (m per step).
        feedback: False: open loop (command the model's IK solution); True: closed loop on the
            measured tip (resolved-rate correction with the model Jacobian, module docstring).
        gain: integrator gain per control step of the closed loop, in (0, 1]; unused open loop.
        displacement_step: the env's ``displacement_step`` (m per step, ``displacement_delta``).
        drive_softening: the env's ``drive_softening`` σ (1/m, >= 0): the drives pull by
            tanh(σy)/σ at a command y > 0 (``cdcr_gym.model.drive_softening``). The IK solves
            for the pulls within the softened range and commands the displacements that give
            them; the closed loop's model holds the pulls of the held commands.

    Use :meth:`from_env` to copy these from an env. :meth:`predict` follows stable-baselines3's
    signature, so the evaluation code can run this and a trained model the same way.
    """

    #: In a displacement action mode, solve for the drive displacements themselves (the tip is
    #: the goal feature); False: convert the tension/shape targets (Track, Pose).
    DRIVE_IK: bool = True

    def __init__(
        self,
        params: RobotParams,
        spec: ObservationSpec,
        action_mode: str = "tension_delta",
        tension_step: float = 0.05,
        length_step: float = 0.002,
        feedback: bool = False,
        gain: float = FEEDBACK_GAIN,
        displacement_step: float = defaults.DISPLACEMENT_STEP,
        *,
        drive_softening: float = 0.0,
    ) -> None:
        self.params = params
        self.drive_softening = check_rate(drive_softening)
        low, high = params.displacement_range
        #: the robot with the range of the drives' pulls (softened: ``drive_softening``)
        self._pull_params = (
            replace(params, displacement_range=(low, float(soften(high, self.drive_softening))))
            if self.drive_softening
            else params
        )
        self.spec = spec
        self.action_mode = validation.choice(action_mode, "action_mode", ACTION_MODES)
        self.tension_step = validation.positive(tension_step, "tension_step", upper=1.0)
        self.length_step = validation.positive(length_step, "length_step")
        self.feedback = validation.flag(feedback, "feedback")
        self.gain = validation.positive(gain, "gain", upper=1.0)
        self.displacement_step = validation.positive(displacement_step, "displacement_step")
        self._model = PCCModel(params)
        self._run_lengths = np.asarray(params.cable_run_lengths)
        sections = np.asarray(params.cable_section)
        self._length_span = np.pi * np.asarray(params.cable_radii) * (sections + 1)
        self._drive_cache: dict[bytes, np.ndarray] = {}

    @classmethod
    def from_env(
        cls, env: Any, feedback: bool = False, gain: float = FEEDBACK_GAIN
    ) -> AnalyticIKController:
        """A controller matched to ``env`` (a CDCREnv or the batched env, possibly wrapped);
        ``feedback`` and ``gain`` as in the class."""
        env = env.unwrapped
        return cls(
            env.params,
            env.observation_spec,
            env.action_mode,
            env.tension_step,
            env.length_step,
            feedback,
            gain,
            env.displacement_step,
            drive_softening=env.drive_softening,
        )

    @property
    def mode(self) -> str:
        """``"closed_loop"`` or ``"open_loop"`` (the label of this controller's results)."""
        return "closed_loop" if self.feedback else "open_loop"

    def targets(self, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """IK solution for ``goal`` (..., 3) m: (tensions (..., C) N, cable lengths (..., C) m)."""
        solution = solve_ik(goal, self.params)
        return solution.tensions, self._model.lengths_from_bending(solution.bending)

    def _unpack(self, obs: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(goal m, tensions N, cable lengths m) from a flat or Dict observation, batched."""
        goal, state = self._goal_and_state(obs)
        return goal, *self._robot_state(state)

    def _goal_and_state(self, obs: Any) -> tuple[np.ndarray, Any]:
        if isinstance(obs, dict):
            return np.asarray(obs["desired_goal"], dtype=np.float64), obs["observation"]
        return self.spec.decode(obs, "goal"), obs

    def _robot_state(self, state: Any) -> tuple[np.ndarray, np.ndarray]:
        """(held tensions N, cable lengths m) from the robot-state fields."""
        tensions = self.spec.decode(state, "tensions") * self.params.max_tension
        lengths = self.spec.decode(state, "cable_lengths") * self._length_span + self._run_lengths
        return tensions, lengths

    # -- closed loop ----------------------------------------------------------------------------
    def features(self, w: np.ndarray) -> np.ndarray:
        """The goal features (..., F) the feedback nulls, on the model, of shapes w (..., S, 2):
        the tip (m)."""
        return self._model.tip_from_bending(w)

    def _feedback_terms(self, obs: Any) -> tuple[np.ndarray, np.ndarray, Any, np.ndarray]:
        """(error (..., F) goal − measured features, feed-forward (..., F), robot state, goal
        for :meth:`targets`) of a flat or Dict observation; the robot state is the
        ``_robot_state`` input."""
        if isinstance(obs, dict):
            goal = np.asarray(obs["desired_goal"], dtype=np.float64)
            measured = np.asarray(obs["achieved_goal"], dtype=np.float64)
            state = obs["observation"]
        else:
            goal, state = self.spec.decode(obs, "goal"), obs
            measured = self.spec.decode(obs, "tip")
        return goal - measured, np.zeros_like(goal), state, goal

    def _goal_features(self, goal: np.ndarray) -> np.ndarray:
        """The features (..., F) of the goal as :meth:`targets` takes it."""
        return np.asarray(goal, dtype=np.float64)

    def _jacobian(self, w: np.ndarray) -> np.ndarray:
        """∂features/∂w of the model, (M, F, 2S), at shapes w (M, S, 2), central differences."""
        m, s = w.shape[0], self._model.n_sections
        h = _JACOBIAN_STEP * np.eye(2 * s).reshape(2 * s, s, 2)
        probes = np.concatenate([w[:, None] + h, w[:, None] - h], axis=1)  # (M, 4S, S, 2)
        f = self.features(probes.reshape(-1, s, 2)).reshape(m, 4 * s, -1)
        return np.swapaxes((f[:, : 2 * s] - f[:, 2 * s :]) / (2.0 * _JACOBIAN_STEP), 1, 2)

    def _closed_loop_targets(
        self, obs: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(target tensions, target lengths, held tensions, held lengths), batched (..., C)."""
        error, forward, state, goal = self._feedback_terms(obs)
        tensions, lengths = self._robot_state(state)
        model = self._model
        batch = tensions.shape[:-1]
        s = model.n_sections
        if self.action_mode == "length_delta":
            held = model.bending_from_lengths(lengths.reshape(-1, lengths.shape[-1]))
        elif self.action_mode in ("displacement", "displacement_delta"):
            # the model's shape of the held command (the measured tensions of a dynamic robot
            # swing with its motion: an integrator on them would not hold still)
            d = self.held_displacements(state)
            p = self.params
            held = solve_displacement_statics(
                model,
                d.reshape(-1, d.shape[-1]),
                p.cable_stiffness,
                p.cable_pretension,
                p.max_tension,
            ).bending
        else:
            held = model.bending_from_tensions(tensions.reshape(-1, tensions.shape[-1]))
        jac = self._jacobian(held)
        jt = np.swapaxes(jac, 1, 2)
        jtj = jt @ jac
        damping = _DAMPING * np.trace(jtj, axis1=1, axis2=2) / (2 * s) + 1e-30
        rhs = jt @ (forward + self.gain * error).reshape(len(held), -1, 1)
        step = np.linalg.solve(jtj + damping[:, None, None] * np.eye(2 * s), rhs)
        w = held + step.reshape(held.shape)
        # far from the goal on the model, pull towards the model's (global) IK solution: the
        # local correction alone can settle in a wrong branch of a redundant robot (tdcr2 poses)
        model_error = self._goal_features(goal).reshape(len(held), -1) - self.features(held)
        size = np.linalg.norm(model_error, axis=-1)
        pull = np.clip(size / (ANCHOR_FRACTION * self.params.length) - 1.0, 0.0, 1.0)
        if np.any(pull > 0.0):
            anchor = model.bending_from_tensions(self.targets(goal)[0]).reshape(held.shape)
            w = w + pull[:, None, None] * (anchor - w)
        w = w * reachable_scale(model, w)[:, None, None]
        target_tensions = minimal_tensions(model, w)[0]
        target_lengths = model.lengths_from_bending(w)
        c = model.n_cables
        return (
            target_tensions.reshape(batch + (c,)),
            target_lengths.reshape(batch + (c,)),
            tensions,
            lengths,
        )

    # -- actions --------------------------------------------------------------------------------
    def action(self, obs: Any) -> np.ndarray:
        """The action (..., C) float32 in [−1, 1]: towards the IK solution (open loop) or the
        corrected command (closed loop)."""
        if self.DRIVE_IK and self.action_mode in ("displacement", "displacement_delta"):
            state = obs["observation"] if isinstance(obs, dict) else obs
            held = self.held_displacements(state)
            if self.feedback:
                target = self._closed_loop_displacements(obs, held)
            else:
                target = self.drive_targets(self._goal_and_state(obs)[0])
            return self._displacement_action(target, held)
        if self.feedback:
            target_tensions, target_lengths, tensions, lengths = self._closed_loop_targets(obs)
        else:
            goal, tensions, lengths = self._unpack(obs)
            target_tensions, target_lengths = self.targets(goal)
        if self.action_mode in ("displacement", "displacement_delta"):
            state = obs["observation"] if isinstance(obs, dict) else obs
            return self.displacement_command(
                target_tensions, target_lengths, self.held_displacements(state)
            )
        return self.command(target_tensions, target_lengths, tensions, lengths)

    def held_displacements(self, state: Any) -> np.ndarray:
        """The held displacements (..., C) m from the observation's ``displacements`` field."""
        low, high = self.params.displacement_range
        x = np.asarray(self.spec.decode(state, "displacements"), dtype=np.float64)
        return low + 0.5 * (x + 1.0) * (high - low)

    def drive_targets(self, goal: np.ndarray) -> np.ndarray:
        """Pulls (..., C) m within the drives' (softened) range whose model equilibrium puts the
        tip at ``goal`` (..., 3) m (:func:`~cdcr_gym.model.ik.solve_displacement_ik`), cached
        per goal (an episode's goal is fixed); without ``drive_softening`` the displacements."""
        goal = np.asarray(goal, dtype=np.float64)
        flat = goal.reshape(-1, 3)
        keys = [np.ascontiguousarray(g).tobytes() for g in flat]
        todo = [i for i, key in enumerate(keys) if key not in self._drive_cache]
        if todo:
            solved = solve_displacement_ik(flat[todo], self._pull_params).displacements
            if len(self._drive_cache) + len(todo) > _CACHE_SIZE:
                self._drive_cache.clear()
            for i, d in zip(todo, solved):
                self._drive_cache[keys[i]] = d
        out = np.stack([self._drive_cache[key] for key in keys])
        return out.reshape(goal.shape[:-1] + (self._model.n_cables,))

    def _closed_loop_displacements(self, obs: Any, held: np.ndarray) -> np.ndarray:
        """The closed loop's displacement target (..., C) m: the drive IK of the goal shifted by
        the model's error at the held displacements ``held`` (..., C) m (module docstring)."""
        error, _, _, goal = self._feedback_terms(obs)
        measured = goal - error
        p = self._pull_params
        c = self._model.n_cables
        flat = soften(held.reshape(-1, c), self.drive_softening)  # the held pulls
        state = solve_displacement_statics(
            self._model, flat, p.cable_stiffness, p.cable_pretension, p.max_tension
        )
        bias = self.features(state.bending) - measured.reshape(-1, 3)
        shifted = goal.reshape(-1, 3) + bias
        start = self.drive_targets(goal).reshape(-1, c)
        target = solve_displacement_ik(shifted, p, start=[start, flat], from_ik=False)
        return target.displacements.reshape(held.shape)

    def displacement_command(
        self, target_tensions: np.ndarray, target_lengths: np.ndarray, held: np.ndarray
    ) -> np.ndarray:
        """The action (..., C) float32 of a displacement mode towards the displacements
        d = s + (T − T0)/k that produce ``target_tensions`` (N) at the shape of
        ``target_lengths`` (m) on the model, from the ``held`` displacements (..., C) m
        (increments scaled so the largest is one step)."""
        p = self.params
        k, t0 = np.asarray(p.cable_stiffness), np.asarray(p.cable_pretension)
        give = np.where(np.isinf(k), 0.0, (target_tensions - t0) / np.where(np.isinf(k), 1.0, k))
        target = self._model.straight_lengths - target_lengths + give
        return self._displacement_action(target, held)

    def _displacement_action(self, target: np.ndarray, held: np.ndarray) -> np.ndarray:
        """The action (..., C) float32 towards the pulls ``target`` (..., C) m from the ``held``
        displacements (absolute: normalised to the range; increments: scaled so the largest is
        one step); with ``drive_softening`` the commands whose pulls they are (a pull beyond
        the softened range: the range's end)."""
        low, high = self.params.displacement_range
        if self.drive_softening:
            high_pull = self._pull_params.displacement_range[1]
            target = command_for_pull(np.minimum(target, high_pull), self.drive_softening)
        if self.action_mode == "displacement":
            action = (2.0 * target - (low + high)) / (high - low)
        else:
            action = (target - held) / self.displacement_step
            largest = np.max(np.abs(action), axis=-1, keepdims=True)
            action = action / np.maximum(largest, 1.0)
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def command(
        self,
        target_tensions: np.ndarray,
        target_lengths: np.ndarray,
        tensions: np.ndarray,
        lengths: np.ndarray,
    ) -> np.ndarray:
        """The action (..., C) float32 that moves the held ``tensions`` (N) or cable ``lengths``
        (m) towards the targets in the action mode (increments scaled, not clipped)."""
        p = self.params
        if self.action_mode == "tension":
            action = 2.0 * target_tensions / p.max_tension - 1.0
        elif self.action_mode == "tension_delta":
            action = (target_tensions - tensions) / (self.tension_step * p.max_tension)
        else:
            action = (target_lengths - lengths) / self.length_step
        if self.action_mode != "tension":
            # scale, not clip: the commands move straight towards the target, and the reachable
            # set is convex (a linear image of the tension box), so length steps never leave it
            # (per-cable clipping can stall at the set's boundary, where the env scales back)
            largest = np.max(np.abs(action), axis=-1, keepdims=True)
            action = action / np.maximum(largest, 1.0)
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, None]:
        """stable-baselines3-style ``predict``: ``(action, None)``."""
        return self.action(observation), None

    __call__ = action
