"""The fit: ``scipy.optimize.least_squares`` over the chosen parameters, with confidence
intervals from the Jacobian.

Residuals: for every row the predicted minus the measured tip, divided by the row's ``sigma``
(3 per row), and, where the data hold tip tangents, their difference divided by ``sigma_dir``
(3 more). The parameters are the scaled variables of :mod:`cdcr_gym.calibration.parameters`
within their bounds (trust-region reflective, ``method="trf"``); the Jacobian is by finite
differences (forward, ``diff_step`` relative to the scaled variable: 1e-6 for the analytic model,
1e-3 for a physics backend, whose settled tips carry a small settling error that a tiny step
would amplify).

Confidence intervals: with J the Jacobian of the weighted residuals at the solution (scaled
variables) and s² = Σ r² / (n − p) the residual variance (n residuals, p parameters), the
covariance is C = (JᵀJ)⁻¹·s² (the Gauss–Newton approximation, as ``scipy.optimize.curve_fit``
with ``absolute_sigma=False``: the given σ weight the rows, their overall scale comes from the
residuals); the 95 % interval is ± t₀.₉₇₅(n − p)·√C_kk, mapped to SI units through the
derivative of the scaling. Parameters that the data cannot tell apart (e.g. E and the cable
radius when only the cables bend the robot: the tips depend on r/E alone) show up as a
near-singular JᵀJ; they are reported as not identifiable (infinite interval) with the
correlations.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import t as student_t

from cdcr_gym.calibration.data import Measurements
from cdcr_gym.calibration.parameters import (
    ParameterSpec,
    parameter_specs,
    resolve_names,
    robot_with,
)
from cdcr_gym.calibration.simulate import (
    AnalyticReplay,
    BackendReplay,
    Prediction,
    backend_class,
)
from cdcr_gym.model.params import RobotParams

__all__ = ["CalibrationResult", "calibrate", "DEFAULT_START"]

#: Start values (SI) of parameters the robot does not carry, when fitted without a given start.
DEFAULT_START = {"friction_coefficient": 0.1, "tip_payload": 0.01}
#: Condition number of the scaled JᵀJ above which parameters are reported not identifiable.
SINGULAR = 1e12


@dataclass
class CalibrationResult:
    """What a calibration found (SI units).

    Attributes:
        names: the fitted parameters, in order.
        start: their start values; ``values``: the fitted values.
        ci95: half-widths of the 95 % confidence intervals (inf: not identifiable).
        std: standard errors; ``correlation``: (p, p) correlation matrix.
        params: the fitted robot; ``backend_kwargs``: the backend's fitted keyword arguments.
        backend: the backend name; ``data``: the measurements.
        before / after: predictions with the start and the fitted values.
        residual_sigma: s, the residual standard deviation in units of the rows' σ.
        identifiable: False if JᵀJ was (near) singular.
        nfev: model runs (the Jacobian's finite differences included); seconds, message,
            success: from the optimiser.
        unsettled: the largest tip motion (m) in the last control step of any row (physics).
    """

    names: list[str]
    start: dict[str, float]
    values: dict[str, float]
    ci95: dict[str, float]
    std: dict[str, float]
    correlation: np.ndarray
    params: RobotParams
    backend_kwargs: dict[str, Any]
    backend: str
    data: Measurements
    before: Prediction
    after: Prediction
    residual_sigma: float
    identifiable: bool
    nfev: int
    seconds: float
    message: str
    success: bool
    unsettled: float = 0.0
    notes: list[str] = field(default_factory=list)

    @property
    def errors_before(self) -> np.ndarray:
        """Tip errors |predicted − measured| (M,) m with the start values."""
        return np.linalg.norm(self.before.tip - self.data.tip, axis=1)

    @property
    def errors_after(self) -> np.ndarray:
        """Tip errors (M,) m with the fitted values."""
        return np.linalg.norm(self.after.tip - self.data.tip, axis=1)


def _residuals(pred: Prediction, data: Measurements) -> np.ndarray:
    parts = [((pred.tip - data.tip) / data.sigma[:, None]).ravel()]
    if data.tip_direction is not None and data.sigma_dir is not None:
        parts.append(((pred.tip_direction - data.tip_direction) / data.sigma_dir[:, None]).ravel())
    return np.concatenate(parts)


def _fit_base(params: RobotParams, data: Measurements) -> tuple[RobotParams, list[str]]:
    """``params`` checked against the data (cable count), with ``max_tension`` raised to the
    largest measured tension if the data exceed it."""
    if data.n_cables != params.n_cables:
        raise ValueError(
            f"the data have {data.n_cables} cable column(s) but the robot has "
            f"{params.n_cables} cables"
        )
    peak = float(data.tensions.max(initial=0.0))
    if peak > params.max_tension:
        return replace(params, max_tension=peak), [
            f"max_tension raised from {params.max_tension:g} N to the largest measured "
            f"tension {peak:g} N"
        ]
    return params, []


def calibrate(
    data: Measurements,
    params: RobotParams,
    fit: str | Sequence[str],
    backend: str = "analytic",
    backend_kwargs: dict[str, Any] | None = None,
    start: dict[str, float] | None = None,
    *,
    ramp_steps: int = 25,
    settle_steps: int = 100,
    max_nfev: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> CalibrationResult:
    """Fit the parameters ``fit`` of the robot ``params`` to the measurements ``data``.

    Args:
        data: the measurements (:func:`~cdcr_gym.calibration.data.read_csv`).
        params: the nominal robot, the start of the fit.
        fit: parameter names or aliases (``"E,mu,payload"`` or a list; see
            :mod:`cdcr_gym.calibration.parameters`).
        backend: "analytic" (CCKA/PCC, batched, frictionless, no gravity) or a physics backend
            ("bullet", "mujoco") replayed through the rows in order
            (:class:`~cdcr_gym.calibration.simulate.BackendReplay`).
        backend_kwargs: fixed backend arguments (e.g. ``{"gravity": True}``); values given
            here for fitted parameters (friction_coefficient, tip_payload) are their start.
        start: start values (SI) of fitted parameters; default the robot's, then
            ``backend_kwargs``'s, then :data:`DEFAULT_START` (0 for offsets and tilt).
        ramp_steps, settle_steps: the physics replay's control steps per row.
        max_nfev: limit on least_squares' steps (its nfev: evaluations outside the
            finite-difference Jacobian; default scipy's, 100·p).
        progress: called with a line of text after every evaluation (e.g. ``print``).

    Returns:
        A :class:`CalibrationResult`.

    Raises:
        ValueError: for unknown or duplicate parameter names, parameters the backend does not
            model, fewer measurements than parameters + 1, or a cable-count mismatch.
    """
    base, notes = _fit_base(params, data)
    cls = backend_class(backend)
    names = resolve_names(list(fit) if not isinstance(fit, str) else fit, base, cls, backend)
    if len(data) < len(names) + 1:
        raise ValueError(
            f"too few points: {len(data)} measurement(s) for {len(names)} parameter(s) "
            f"{names}; need at least {len(names) + 1}"
        )
    stray = sorted(set(start or {}) - set(names))
    if stray:
        raise ValueError(f"start values given for {stray}, which are not fitted (fitted: {names})")
    fixed = dict(backend_kwargs or {})
    start_values: dict[str, float] = {}
    for n in names:
        if start and n in start:
            start_values[n] = float(start[n])
        elif n == "youngs_modulus":
            start_values[n] = base.youngs_modulus
        elif n == "cable_radius":
            start_values[n] = max(base.cable_radii)
        elif n in fixed:
            start_values[n] = float(fixed.pop(n))
        else:
            start_values[n] = DEFAULT_START.get(n, 0.0)
    model: AnalyticReplay | BackendReplay
    if cls is None:
        model = AnalyticReplay(data, base, fixed)
    else:
        model = BackendReplay(data, base, cls, fixed, ramp_steps, settle_steps)
        model.name = backend
    specs = parameter_specs(names, base, start_values)
    x0 = np.array([s.to_x(start_values[s.name]) for s in specs])
    lo, hi = (np.array(b) for b in zip(*(s.bounds_x() for s in specs)))
    x0 = np.clip(x0, lo + 1e-6, hi - 1e-6)  # trf starts strictly inside the bounds

    def values_of(x: np.ndarray) -> dict[str, float]:
        return {s.name: s.from_x(float(v)) for s, v in zip(specs, x)}

    count = [0]

    def residuals(x: np.ndarray) -> np.ndarray:
        count[0] += 1
        r = _residuals(model(values_of(x)), data)
        if progress is not None:
            shown = ", ".join(f"{k}={v:.6g}" for k, v in values_of(x).items())
            progress(f"  eval {count[0]:3d}: cost {0.5 * float(r @ r):.6g}  ({shown})")
        return r

    t0 = time.perf_counter()
    before = model(start_values)
    result = least_squares(
        residuals,
        x0,
        bounds=(lo, hi),
        method="trf",
        x_scale=1.0,
        diff_step=1e-6 if cls is None else 1e-3,
        max_nfev=max_nfev,
    )
    seconds = time.perf_counter() - t0
    values = values_of(result.x)
    after = model(values)
    n_res, p = result.fun.size, len(specs)
    dof = max(n_res - p, 1)
    s2 = float(result.fun @ result.fun) / dof
    jtj = result.jac.T @ result.jac
    identifiable = bool(np.linalg.cond(jtj) < SINGULAR)
    cov = np.linalg.pinv(jtj) * s2
    sd_x = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    denom = np.outer(sd_x, sd_x)
    corr = np.divide(cov, denom, out=np.full_like(cov, np.nan), where=denom > 0)
    tq = float(student_t.ppf(0.975, dof))
    std, ci = {}, {}
    for k, s in enumerate(specs):
        d = abs(s.derivative(float(result.x[k])))
        std[s.name] = d * sd_x[k] if identifiable else math.inf
        ci[s.name] = tq * std[s.name]
    if not identifiable:
        notes.append(
            "JᵀJ is singular: these data cannot tell some fitted parameters apart (see the "
            "correlations); fix one of them (e.g. keep the cable radius when fitting E without "
            "gravity)"
        )
    at_bound = [s.name for k, s in enumerate(specs) if result.active_mask[k] != 0]
    if at_bound:
        notes.append(f"at a bound of its range: {at_bound}")
    return CalibrationResult(
        names=names,
        start=start_values,
        values=values,
        ci95=ci,
        std=std,
        correlation=corr,
        params=robot_with(base, values),
        backend_kwargs=model.backend_kwargs(values),
        backend=backend,
        data=data,
        before=before,
        after=after,
        residual_sigma=math.sqrt(s2),
        identifiable=identifiable,
        nfev=count[0] + 2,  # every model run, finite differences and before/after included
        seconds=seconds,
        message=str(result.message),
        success=bool(result.success),
        unsettled=max(before.unsettled, after.unsettled),
        notes=notes,
    )


def specs_of(result: CalibrationResult) -> list[ParameterSpec]:
    """The parameter specs of a result (units for reports)."""
    return parameter_specs(result.names, result.params, result.start)
