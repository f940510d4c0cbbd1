"""Per-episode domain randomisation, and sensor/actuator imperfections (SPEC §7).

Both are configured by one YAML-friendly mapping each, given to the env as ``randomize=`` and
``imperfections=`` (``gymnasium.make(id, randomize={...}, imperfections={...})``, the same in
``gymnasium.make_vec``), and both draw only from the env's own generator (the single env's
``np_random``, the vector env's per-env generators), in a fixed order, so that the single and the
vector env draw the same values for the same seed. Both are off by default, and then draw
nothing: the env is bit-identical to one without them.

**Domain randomisation** (``randomize``: parameter → ``[low, high]`` uniform range, or one
number = fixed value). Drawn at every reset, before the start shape and the goal, in the order of
:data:`RANDOMIZABLE`; the drawn values are in ``info["randomized/<name>"]`` (at the reset and at
every step of the episode).

| name                   | unit  | meaning                                                    | bounds     |
|------------------------|-------|------------------------------------------------------------|------------|
| ``youngs_modulus``     | Pa    | backbone E (bending stiffness EI ∝ E)                      | > 0        |
| ``cable_radius``       | m     | distance of every cable from the backbone axis             | > 0        |
| ``backbone_density``   | kg/m³ | backbone material density (mass)                           | >= 0       |
| ``disk_mass``          | kg    | mass of each spacer disk                                   | >= 0       |
| ``tip_payload``        | kg    | point mass added at the tip disk                           | >= 0       |
| ``friction_coefficient`` | –   | cable–disk capstan μ (``cdcr_gym.model.friction``)         | [0, 1]     |
| ``base_tilt``          | rad   | tilt of the base from upright, about a horizontal axis     | [0, π]     |
|                        |       | whose azimuth is drawn uniformly in [0, 2π) (reported as   |            |
|                        |       | ``base_tilt_azimuth``)                                     |            |
| ``gravity``            | –     | probability in [0, 1] that gravity is on (one number);     | [0, 1]     |
|                        |       | reported as 1.0 (on) or 0.0 (off)                          |            |

A backend applies the parameters it models (:attr:`Backend.randomizable`) and ignores the
others, which are still drawn and reported: the analytic CCKA backend applies
``youngs_modulus`` and ``cable_radius`` per robot (a stiffer or thinner-routed robot bends less
under the same tensions; cable radius also scales the cable-length changes). Goals are sampled
on the *nominal* robot's reachable set (the robot's parameters are unknown to whoever sets the
goal), so a robot drawn less compliant than nominal may not reach the rim of it.

**Imperfections** (``imperfections``: name → value):

| name                   | unit   | meaning                                                        |
|------------------------|--------|----------------------------------------------------------------|
| ``tip_noise``          | m      | σ of Gaussian noise on each observed tip coordinate, per step  |
| ``cable_length_noise`` | m      | σ on each observed cable length, per step                      |
| ``tension_noise``      | N      | σ on each observed tension, per step                           |
| ``tip_bias``           | m      | σ of a per-episode constant offset of each tip coordinate     |
| ``cable_length_bias``  | m      | σ of a per-episode offset of each observed cable length        |
| ``tension_bias``       | N      | σ of a per-episode offset of each observed tension             |
| ``action_delay``       | steps  | integer 0 <= k <= 10 000: the action of step t is applied at step t + k |
| ``tension_lag``        | steps  | time constant τ > 0 of a first-order settling of the robot:   |
|                        |        | the shape follows the static shape of the actuator tensions   |
|                        |        | with a lag (per step the gap closes by 1 − e^(−1/τ))          |
| ``tension_response``   | rad/step | natural frequency ω > 0 (per control step) of a critically  |
|                        |        | damped second-order settling of the robot: the shape is that  |
|                        |        | of the actuator tensions filtered (exact for tensions held    |
|                        |        | over a step); a dynamic robot's settling for a quasi-static   |
|                        |        | model (bullet: ω ≈ 0.44, docs/sim2real.md)                    |
| ``tension_rate_limit`` | N/step | largest change of an actuator's tension per control step      |
| ``actuator_noise``     | N      | σ of Gaussian noise on each applied tension, per step          |

Sensor noise and bias act on what the agent observes (the ``observation`` / flat vector), never
on the physics, the reward, success or ``info`` (which hold the true values); a noisy
observation is clipped to the observation space (a sensor saturates at its range); in the
goal-conditioned Dict the ``achieved_goal`` stays exact, because the reward is computed from it.
Actuator imperfections act on the tensions the actuators apply (``info["tensions"]`` and the
observation report them): the delay holds actions in a queue that a reset fills with the action
that holds the reset state (0 for increments, the reset tensions for absolute tensions); the
rate limit caps each actuator's change at ``tension_rate_limit`` per step; actuator noise is
added and clipped to [0, max_tension]. The settling models (response, then lag; both start at
rest at the reset tensions) act on the robot, not on the actuators: the quasi-static backend
takes the static shape of the *filtered* actuator tensions, while the actuator tensions are
reported as a tension sensor at the actuator would (as on the dynamic bullet backend, where the
commanded tension acts at once and the shape settles). Response, lag, rate limit and actuator
noise need a tension action mode.

Draw order per env: at a reset the randomised parameters, then the biases (tip, cable lengths,
tensions); per step the actuator noise (one normal vector of C entries, after the action), then
the observation noise (one normal vector: the entries of the noisy channels among tip, cable
lengths, tensions, in that order).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import Readings
from cdcr_gym.model.params import RobotParams

__all__ = [
    "RANDOMIZABLE",
    "IMPERFECTIONS",
    "INFO_PREFIX",
    "DomainRandomization",
    "Imperfections",
]

#: Prefix of the randomised parameters' keys in ``info``.
INFO_PREFIX = "randomized/"

#: Randomisable parameter → (unit, lowest allowed value, highest allowed value), draw order.
RANDOMIZABLE: dict[str, tuple[str, float, float]] = {
    "youngs_modulus": ("Pa", 0.0, math.inf),
    "cable_radius": ("m", 0.0, math.inf),
    "backbone_density": ("kg/m^3", 0.0, math.inf),
    "disk_mass": ("kg", 0.0, math.inf),
    "tip_payload": ("kg", 0.0, math.inf),
    "friction_coefficient": ("-", 0.0, 1.0),
    "base_tilt": ("rad", 0.0, math.pi),
    "gravity": ("probability", 0.0, 1.0),
}
_STRICTLY_POSITIVE = ("youngs_modulus", "cable_radius")

#: Longest ``action_delay`` (control steps; the queue holds one action per step and env).
MAX_ACTION_DELAY = 10_000
#: Imperfection → unit (all >= 0; ``action_delay`` an integer).
IMPERFECTIONS: dict[str, str] = {
    "tip_noise": "m",
    "cable_length_noise": "m",
    "tension_noise": "N",
    "tip_bias": "m",
    "cable_length_bias": "m",
    "tension_bias": "N",
    "action_delay": "steps",
    "tension_lag": "steps",
    "tension_response": "rad/step",
    "tension_rate_limit": "N/step",
    "actuator_noise": "N",
}


def _unknown(kind: str, key: Any, known: Sequence[str]) -> ValueError:
    close = difflib.get_close_matches(str(key), known, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return ValueError(f"{kind} has an unknown key {key!r}{hint} (known: {sorted(known)})")


def _mapping(value: Any, name: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ValueError(f"{name} must be a mapping (name -> value) or None, got {value!r}")
    return dict(value)


def _real(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    return float(value)


class DomainRandomization:
    """The ``randomize`` mapping, validated, and its per-episode draws.

    Args:
        spec: parameter → ``[low, high]`` (uniform) or a number (fixed); ``gravity`` → a
            probability. None or ``{}``: off.
        params: the nominal robot (``cable_radius`` needs one radius for every cable).
        backend: the backend, or None; one with a ``check_randomization(ranges)`` method
            (MuJoCo) refuses the ranges of the parameters it applies that it cannot simulate.

    Raises:
        ValueError: naming ``randomize[<name>]`` for an unknown name, a malformed or reversed
            range, or a value outside the parameter's bounds (table in the module docstring).
    """

    def __init__(
        self, spec: Mapping[str, Any] | None, params: RobotParams, backend: Any = None
    ) -> None:
        raw = _mapping(spec, "randomize")
        ranges: dict[str, tuple[float, float]] = {}
        for key in raw:
            if key not in RANDOMIZABLE:
                raise _unknown("randomize", key, tuple(RANDOMIZABLE))
        for key in RANDOMIZABLE:  # fixed order: the draw order
            if key not in raw:
                continue
            name = f"randomize[{key!r}]"
            value = raw[key]
            if isinstance(value, (list, tuple, np.ndarray)) and key != "gravity":
                if len(value) != 2:
                    raise ValueError(f"{name} must be [low, high] or one number, got {value!r}")
                low, high = _real(value[0], name), _real(value[1], name)
            else:
                low = high = _real(value, name)
            _, lowest, highest = RANDOMIZABLE[key]
            bad = not (math.isfinite(low) and math.isfinite(high)) or low > high
            bad = bad or low < lowest or high > highest
            bad = bad or (key in _STRICTLY_POSITIVE and low <= 0.0)
            if bad:
                rule = "> 0" if key in _STRICTLY_POSITIVE else f">= {lowest}"
                upper = "" if math.isinf(highest) else f" and <= {highest:g}"
                raise ValueError(
                    f"{name} must be finite, {rule}{upper}, with low <= high, got {value!r}"
                )
            ranges[key] = (low, high)
        if "cable_radius" in ranges and len(set(params.cable_radii)) != 1:
            raise ValueError(
                "randomize['cable_radius'] needs a robot with one cable radius, got radii "
                f"{params.cable_radii}"
            )
        self.ranges = ranges
        self.params = params
        self._check_extreme_robot()
        check = getattr(backend, "check_randomization", None)
        applied = {k: v for k, v in ranges.items() if k in getattr(backend, "randomizable", ())}
        if check is not None and applied:
            check(applied)  # the backend's own limits (e.g. MuJoCo: payload, stability)

    def _check_extreme_robot(self) -> None:
        """The robot at the ranges' extreme corner must be one ``RobotParams`` accepts, and its
        observations must stay in the nominal robot's Box.

        Bending scales with r/E (``cdcr_gym.backends.analytic``): the softest, widest-routed
        robot (lowest E, largest r) bends most, so it must keep every section within 180°
        (``RobotParams``' bend limit; also its disk radius must exceed the cable radius); its
        cable-length changes r·θ must stay within the observation's ±π r₀ per section.
        """
        keys = [k for k in ("youngs_modulus", "cable_radius") if k in self.ranges]
        if not keys:
            return
        p = self.params
        youngs = self.ranges["youngs_modulus"][0] if "youngs_modulus" in self.ranges else None
        radius = self.ranges["cable_radius"][1] if "cable_radius" in self.ranges else None
        ratio = 1.0 if radius is None else radius / p.cable_radii[0]
        named = " and ".join(f"randomize[{k!r}]={list(self.ranges[k])}" for k in keys)
        corner = ", ".join(
            f"{k}={v!r}"
            for k, v in (("youngs_modulus", youngs), ("cable_radius", radius))
            if v is not None
        )
        try:
            extreme = dataclasses.replace(
                p,
                sections=tuple(
                    dataclasses.replace(s, cable_radius=s.cable_radius * ratio) for s in p.sections
                ),
                length=None,  # type: ignore[arg-type]  # derived from the sections
                n_disks=None,  # type: ignore[arg-type]
                cable_radius=None,
                youngs_modulus=p.youngs_modulus if youngs is None else youngs,
            )
        except ValueError as exc:
            raise ValueError(
                f"{named}: the robot at the range's extreme ({corner}) is not a valid robot: "
                f"{exc}; narrow the range"
            ) from None
        bend = max(extreme.section_bend_limits)
        if ratio * bend > math.pi * (1.0 + 1e-12):
            raise ValueError(
                f"{named}: the robot at the range's extreme ({corner}) bends to "
                f"{math.degrees(bend):.1f}° with cable lengths changing by up to "
                f"{ratio * bend / math.pi:.3g}·π·r₀ per section, outside the observation's "
                f"±π·r₀; narrow the range"
            )

    @property
    def enabled(self) -> bool:
        """Whether any parameter is randomised."""
        return bool(self.ranges)

    @property
    def reported(self) -> tuple[str, ...]:
        """The names reported in ``info`` (``base_tilt`` adds ``base_tilt_azimuth``)."""
        names = list(self.ranges)
        if "base_tilt" in self.ranges:
            names.insert(names.index("base_tilt") + 1, "base_tilt_azimuth")
        return tuple(names)

    def sample(self, rng: np.random.Generator) -> dict[str, float]:
        """One episode's values, drawn from ``rng`` in the order of :data:`RANDOMIZABLE`.

        A range draws one ``rng.uniform(low, high)`` (a fixed value draws nothing); ``gravity``
        draws one ``rng.random() < p``; ``base_tilt`` also draws its azimuth in [0, 2π).
        """
        out: dict[str, float] = {}
        for key, (low, high) in self.ranges.items():
            if key == "gravity":
                out[key] = float(rng.random() < low) if 0.0 < low < 1.0 else low
                continue
            out[key] = float(rng.uniform(low, high)) if high > low else low
            if key == "base_tilt":
                out["base_tilt_azimuth"] = float(rng.uniform(0.0, 2.0 * math.pi))
        return out


class Imperfections:
    """The ``imperfections`` mapping, validated, and its state for N envs.

    Args:
        spec: name → value (module docstring). None or ``{}``: off.
        params: the robot.
        num_envs: N.
        commands_tensions: whether the action mode commands tensions (``tension``,
            ``tension_delta``); ``tension_rate_limit`` and ``actuator_noise`` need it.
        absolute_tensions: whether actions are absolute tensions (``tension``): the delay
            queue's reset action then holds the reset tensions.

    Raises:
        ValueError: naming ``imperfections[<name>]`` for an unknown name, a negative or
            non-finite σ, a non-integer or negative delay, a rate limit <= 0, or a tension
            imperfection with a cable-length action mode.
    """

    def __init__(
        self,
        spec: Mapping[str, Any] | None,
        params: RobotParams,
        num_envs: int,
        *,
        commands_tensions: bool = True,
        absolute_tensions: bool = False,
    ) -> None:
        raw = _mapping(spec, "imperfections")
        for key in raw:
            if key not in IMPERFECTIONS:
                raise _unknown("imperfections", key, tuple(IMPERFECTIONS))
        values: dict[str, float] = {}
        for key, value in raw.items():
            name = f"imperfections[{key!r}]"
            if key == "action_delay":
                values[key] = validation.integer(value, name, 0)
                if values[key] > MAX_ACTION_DELAY:
                    raise ValueError(
                        f"{name} must be an integer in [0, {MAX_ACTION_DELAY}] (control "
                        f"steps), got {value!r}"
                    )
            elif key in ("tension_rate_limit", "tension_lag", "tension_response"):
                values[key] = validation.positive(value, name)
            else:
                values[key] = validation.positive(value, name, allow_zero=True)
        if not commands_tensions:
            for key in ("tension_response", "tension_lag", "tension_rate_limit", "actuator_noise"):
                if key in values:
                    raise ValueError(
                        f"imperfections[{key!r}] needs a tension action mode ('tension' or "
                        f"'tension_delta'), not cable-length increments"
                    )
        self.values = values
        self.params = params
        self.num_envs = n = num_envs
        c = params.n_cables
        self.max_tension = float(params.max_tension)
        self.absolute_tensions = absolute_tensions
        get = values.get
        self.delay = int(get("action_delay", 0))
        self.rate_limit = get("tension_rate_limit")
        self.omega = get("tension_response")
        lag = get("tension_lag")
        self.lag_fraction = None if lag is None else -math.expm1(-1.0 / lag)
        self.actuator_sigma = get("actuator_noise", 0.0)
        self.noise = (
            get("tip_noise", 0.0),
            get("cable_length_noise", 0.0),
            get("tension_noise", 0.0),
        )
        self.bias_sigma = (
            get("tip_bias", 0.0),
            get("cable_length_bias", 0.0),
            get("tension_bias", 0.0),
        )
        self.senses = any(self.noise) or any(self.bias_sigma)
        self.actuates = (
            self.rate_limit is not None
            or self.lag_fraction is not None
            or self.omega is not None
            or self.actuator_sigma > 0
        )
        self.bias = (np.zeros((n, 3)), np.zeros((n, c)), np.zeros((n, c)))
        self.queue = np.zeros((n, self.delay, c))
        self.applied = np.zeros((n, c))
        self.lagged = np.zeros((n, c))  # first-order lag output (N)
        self.response = np.zeros((n, c))  # second-order response: its output (N) and rate
        self.response_rate = np.zeros((n, c))  # (N per step)

    @property
    def enabled(self) -> bool:
        """Whether anything is imperfect (a zero σ or a zero delay counts as off)."""
        return self.senses or self.actuates or self.delay > 0

    @property
    def acts(self) -> bool:
        """Whether the commands reach the robot changed (delayed, or by the actuators)."""
        return self.actuates or self.delay > 0

    # -- reset ----------------------------------------------------------------------------------
    def draw_biases(self, idx: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
        """Draw the per-episode biases of envs ``idx`` (one generator each)."""
        for i, rng in zip(idx.tolist(), rngs):
            for bias, sigma in zip(self.bias, self.bias_sigma):
                if sigma > 0.0:
                    bias[i] = sigma * rng.standard_normal(bias.shape[1])

    def reset(self, idx: np.ndarray, tensions: np.ndarray) -> None:
        """Start envs ``idx`` at rest under ``tensions`` (len(idx), C) N: fill the delay queue
        with the action that holds them, and the rate limiter's state."""
        if self.delay:
            if self.absolute_tensions:
                hold = 2.0 * tensions / self.max_tension - 1.0
                self.queue[idx] = hold[:, None, :]
            else:
                self.queue[idx] = 0.0
        self.applied[idx] = tensions
        self.response[idx] = tensions
        self.lagged[idx] = tensions
        self.response_rate[idx] = 0.0

    # -- step -----------------------------------------------------------------------------------
    def delayed(self, action: np.ndarray) -> np.ndarray:
        """The action (N, C) to apply now: ``action`` enters the queue, the oldest leaves."""
        if not self.delay:
            return action
        out = self.queue[:, 0].copy()
        self.queue[:, :-1] = self.queue[:, 1:]
        self.queue[:, -1] = action
        return out

    def actuate(
        self,
        commanded: np.ndarray,
        rngs: Sequence[np.random.Generator | None],
        active: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(shape tensions, actuator tensions), each (N, C) N, for commanded tensions (N, C) N.

        The actuators: rate limit (from their last noise-free output), then noise drawn from
        the generators of the ``active`` envs (all if None; the others get none), clipped — the
        actuator tensions, which the env reports. The robot's settling (second-order response,
        then first-order lag) filters them into the tensions whose static shape the
        quasi-static backend takes this step.
        """
        target = commanded
        if self.rate_limit is not None:
            step = np.clip(commanded - self.applied, -self.rate_limit, self.rate_limit)
            target = self.applied + step
        self.applied = target.copy()
        actuator = target.copy()
        if self.actuator_sigma > 0.0:
            for i, rng in enumerate(rngs):
                if rng is not None and (active is None or active[i]):
                    actuator[i] += self.actuator_sigma * rng.standard_normal(actuator.shape[1])
            np.clip(actuator, 0.0, self.max_tension, out=actuator)
        shape = actuator
        if self.omega is not None:
            shape = self._respond(shape)
        if self.lag_fraction is not None:
            self.lagged = self.lagged + (shape - self.lagged) * self.lag_fraction
            shape = self.lagged
        return shape.copy(), actuator

    def _respond(self, commanded: np.ndarray) -> np.ndarray:
        """One step of x'' + 2ωx' + ω²x = ω²u with u = ``commanded`` held over the step (exact:
        e = x − u follows (e₀ + (v₀ + ωe₀)t)·e^(−ωt), t in steps)."""
        w = float(self.omega)  # type: ignore[arg-type]
        decay = math.exp(-w)
        e0 = self.response - commanded
        b = self.response_rate + w * e0
        self.response = commanded + (e0 + b) * decay
        self.response_rate = (self.response_rate - w * b) * decay
        return self.response

    def sense(self, readings: Readings, rngs: Sequence[np.random.Generator | None]) -> Readings:
        """The readings the agent observes: true readings plus bias and per-step noise."""
        if not self.senses:
            return readings
        fields = [readings.tip.copy(), readings.cable_lengths.copy(), readings.tensions.copy()]
        for field, bias, bias_sigma in zip(fields, self.bias, self.bias_sigma):
            if bias_sigma > 0.0:
                field += bias
        noisy = [(f, sigma) for f, sigma in zip(fields, self.noise) if sigma > 0.0]
        if noisy:
            # one draw per env: the noisy channels' entries concatenated (tip, lengths, tensions)
            sigmas = np.concatenate([np.full(f.shape[1], sigma) for f, sigma in noisy])
            draws = np.zeros((len(rngs), sigmas.size))
            for i, rng in enumerate(rngs):
                if rng is not None:
                    draws[i] = rng.standard_normal(sigmas.size)
            draws *= sigmas
            start = 0
            for f, _ in noisy:
                f += draws[:, start : start + f.shape[1]]
                start += f.shape[1]
        tip, lengths, tensions = fields
        return readings._replace(tip=tip, cable_lengths=lengths, tensions=tensions)
