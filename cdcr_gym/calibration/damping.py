"""Fitting the damping ratio ζ (and the first-mode frequency ω₁) from a recorded step response.

The recording (``cdcr-gym calibrate --damping-step STEP.csv``) is a CSV with a header row and
one time-stamped row per sample (``#`` starts a comment line, blank lines are skipped):

========= ==== ==================================================================================
column    unit meaning
========= ==== ==================================================================================
``t``     s    time since the step command (the command changes at t = 0; rows with t < 0,
               optional, are the settled state before it and are not fitted); increasing.
``x,y,z`` m    tip position (last disk centre) in the base frame R0 (any fixed frame works: only
               the motion along its main direction is used).
========= ==== ==================================================================================

The step command: the robot rests under one set of cable tensions (or tendon displacements)
and at t = 0 they change at once to another set, held constant while the tip is recorded until
it has settled (a few 1/(ζ·ω₁)). Any step works (loading or unloading, any cables) as long as
the tip moves by much more than the measurement noise; releasing a pulled cable is the
simplest (the "released tip" of ``docs/dynamics.md``).

Model: the tip's deflection s(t) along the main direction of its motion (the first principal
axis of the positions at t >= 0) from ``FIT_START`` = 0.1 s after the step is fitted with the
free response of one damped mode, s(t) = c + e^(−ζω₁t)·(a·C(t) + b·S(t)), with
C, S = cos(ω_d t), sin(ω_d t)/ω_d (ω_d = ω₁√(1−ζ²)), = 1, t (ζ = 1) or cosh, sinh/… (ζ > 1): a second-order model of the first
mode, valid for both physics backends because their damping is stiffness-proportional (D = β·K,
``docs/dynamics.md``): mode k has ζ_k = ζ₁·ω_k/ω₁ (≈ 6·ζ₁ for the second mode), so after a
step the higher modes are gone within a small part of the first mode's decay, and the backends
deliver the stated ``damping_ratio`` on that first mode. a, b, c are linear (solved at every
evaluation); ω₁ and ζ by ``scipy.optimize.least_squares`` from a grid of starts. ζ is well-posed
whenever the decay is visible (ζ up to ~1.5); ω₁ too for ζ < 1 (with a visible overshoot); for
an over-damped response ω₁ and ζ trade off and only the slow rate is determined, which the
result reports (``well_posed``).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.optimize

__all__ = [
    "StepResponse",
    "DampingFit",
    "read_step_csv",
    "write_step_csv",
    "fit_second_order",
    "fit_step_response",
    "simulate_step",
    "run_step_fit",
]

COLUMNS = ("t", "x", "y", "z")
#: The fit starts 0.1 s after the step (s): before, the higher modes still move (stiffness-
#: proportional damping gives the second ζ₂ ≈ 6·ζ₁ at ω₂ ≈ 6·ω₁: decayed to ~1 % by then for
#: ζ₁ >= 0.3 on the shipped robots); fitting from t = 0 overestimates ζ by ~5 % at ζ = 0.3.
FIT_START = 0.1


@dataclass(frozen=True)
class StepResponse:
    """A recorded step response: times ``t`` (N,) s (step at t = 0) and tips (N, 3) m."""

    t: np.ndarray
    tips: np.ndarray
    source: str = "<array>"


@dataclass(frozen=True)
class DampingFit:
    """The fitted first mode: ``damping_ratio`` ζ, ``frequency_hz`` ω₁/2π (undamped),
    ``rms_m`` the residual RMS (m), ``amplitude_m`` the step's size along ``axis`` (3,),
    ``n_rows`` fitted, and ``well_posed`` (False: over-damped, ω₁ and ζ traded off)."""

    damping_ratio: float
    frequency_hz: float
    rms_m: float
    amplitude_m: float
    n_rows: int
    well_posed: bool
    axis: tuple[float, float, float]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


# -- file ------------------------------------------------------------------------------------
def read_step_csv(path: str | Path) -> StepResponse:
    """Read a step-response CSV (module docstring).

    Raises:
        ValueError: naming the file, the 1-based line and the column, for a missing file or
            column, a non-numeric or non-finite value, a row of the wrong length, times not
            increasing, or fewer than 10 rows at t >= 0.
    """
    path = Path(path)
    name = path.name
    if not path.is_file():
        raise ValueError(f"step-response file {str(path)!r} does not exist")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{name}: not a UTF-8 text file ({exc})") from None
    rows = [
        (i, line)
        for i, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not rows:
        raise ValueError(f"{name}: no header and no data rows")
    cells = list(csv.reader([line for _, line in rows], skipinitialspace=True))
    header_line, header = rows[0][0], [c.strip() for c in cells[0]]
    for col in COLUMNS:
        if col not in header:
            raise ValueError(
                f"{name} line {header_line} (header): missing column {col!r} "
                f"(need {', '.join(COLUMNS)}), got {header}"
            )
    index = [header.index(col) for col in COLUMNS]
    values = np.empty((len(rows) - 1, 4))
    for r, ((line, _), row) in enumerate(zip(rows[1:], cells[1:])):
        if len(row) != len(header):
            raise ValueError(
                f"{name} line {line}: {len(row)} values for {len(header)} columns {header}"
            )
        for c, (col, j) in enumerate(zip(COLUMNS, index)):
            text_value = row[j].strip()
            try:
                value = float(text_value)
            except ValueError:
                raise ValueError(
                    f"{name} line {line}, column {col!r}: {text_value!r} is not a number"
                ) from None
            if not math.isfinite(value):
                raise ValueError(
                    f"{name} line {line}, column {col!r}: {text_value!r} is not finite"
                )
            values[r, c] = value
        if r > 0 and values[r, 0] <= values[r - 1, 0]:
            raise ValueError(
                f"{name} line {line}, column 't': times must increase, got {values[r, 0]!r} s "
                f"after {values[r - 1, 0]!r} s"
            )
    if np.count_nonzero(values[:, 0] >= 0.0) < 10:
        raise ValueError(
            f"{name}: {np.count_nonzero(values[:, 0] >= 0.0)} rows at t >= 0, need >= 10 "
            "(the response after the step at t = 0)"
        )
    return StepResponse(values[:, 0], values[:, 1:], str(path))


def write_step_csv(path: str | Path, response: StepResponse, comment: str = "") -> None:
    """Write ``response`` in the format :func:`read_step_csv` reads (``comment``: ``#`` lines)."""
    lines = [f"# {c}" for c in comment.splitlines()] + [",".join(COLUMNS)]
    lines += [f"{t:.6f},{x:.7e},{y:.7e},{z:.7e}" for t, (x, y, z) in zip(response.t, response.tips)]
    Path(path).write_text("\n".join(lines) + "\n")


# -- model -----------------------------------------------------------------------------------
def _basis(t: np.ndarray, omega: float, zeta: float) -> np.ndarray:
    """(N, 3) columns e^(−ζωt)·C(t), e^(−ζωt)·S(t), 1 of the free response (module docstring)."""
    decay = np.exp(-zeta * omega * t)
    q = omega * omega * (1.0 - zeta * zeta)
    if q > 1e-12 * omega * omega:
        wd = math.sqrt(q)
        c, s = np.cos(wd * t), np.sin(wd * t) / wd
    elif q < -1e-12 * omega * omega:
        r = math.sqrt(-q)
        # e^(−ζωt)·cosh(rt) etc. without overflow: exponents −(ζω ∓ r)·t
        e1, e2 = np.exp(-(zeta * omega - r) * t), np.exp(-(zeta * omega + r) * t)
        return np.column_stack((0.5 * (e1 + e2), 0.5 * (e1 - e2) / r, np.ones_like(t)))
    else:
        c, s = np.ones_like(t), t.copy()
    return np.column_stack((decay * c, decay * s, np.ones_like(t)))


def _residual(params: np.ndarray, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    basis = _basis(t, math.exp(params[0]), params[1])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return basis @ coef - x


def fit_second_order(t: np.ndarray, x: np.ndarray) -> tuple[float, float, float]:
    """(ω₁ rad/s, ζ, RMS residual) of x(t) ≈ c + e^(−ζω₁t)·(a·C(t) + b·S(t)) (module
    docstring), t (N,) s from the step (or release), x (N,) m; least squares from a grid of
    starts (ω₁ from 1/(t span) to the Nyquist rate, ζ from 0.02 to 2)."""
    t = np.asarray(t, float) - float(t[0])
    x = np.asarray(x, float)
    span, dt = float(t[-1]), float(np.median(np.diff(t)))
    omegas = np.geomspace(2.0 * math.pi / span, 0.5 * math.pi / dt, 40)
    zetas = (0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0)
    grid = [
        (float(np.sum(_residual(np.array([math.log(w), z]), t, x) ** 2)), w, z)
        for w in omegas
        for z in zetas
    ]
    grid.sort()
    best = None
    for _, w, z in grid[:6]:
        res = scipy.optimize.least_squares(
            _residual,
            np.array([math.log(w), z]),
            args=(t, x),
            bounds=([math.log(omegas[0] / 4), 1e-4], [math.log(omegas[-1] * 2), 5.0]),
            x_scale=np.array([0.1, 0.05]),
            xtol=1e-12,
            ftol=1e-12,
        )
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None  # the grid has starts
    rms = math.sqrt(2.0 * best.cost / x.size)
    return math.exp(best.x[0]), float(best.x[1]), rms


def fit_step_response(response: StepResponse | str | Path, start: float = FIT_START) -> DampingFit:
    """Fit ζ and ω₁ of the first mode to a step response (a :class:`StepResponse` or a CSV
    path, :func:`read_step_csv`): the rows at t >= ``start`` s (default 0.1 s), projected on
    the main direction of the tip's motion at t >= 0 (module docstring)."""
    if not isinstance(response, StepResponse):
        response = read_step_csv(response)
    after = response.t >= 0.0
    centred = response.tips[after] - response.tips[after].mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]
    late = response.t[after] >= start
    if np.count_nonzero(late) < 10:
        raise ValueError(
            f"{response.source}: {np.count_nonzero(late)} rows at t >= {start} s, need >= 10"
        )
    t, x = response.t[after][late], centred[late] @ axis
    omega, zeta, rms = fit_second_order(t, x)
    amplitude = float(np.ptp(x))
    if rms > 0.5 * amplitude:
        raise ValueError(
            f"{response.source}: the step response does not look like a decaying mode "
            f"(fit residual {rms:.3g} m against a motion of {amplitude:.3g} m)"
        )
    return DampingFit(
        damping_ratio=zeta,
        frequency_hz=omega / (2.0 * math.pi),
        rms_m=rms,
        amplitude_m=amplitude,
        n_rows=int(t.size),
        well_posed=zeta < 0.9,
        axis=(float(axis[0]), float(axis[1]), float(axis[2])),
    )


# -- synthetic data --------------------------------------------------------------------------
def simulate_step(
    backend: Any,
    before: np.ndarray,
    after: np.ndarray,
    duration: float,
    settled_rows: int = 5,
) -> StepResponse:
    """Record a step response on a physics ``backend`` (one robot): settled under tensions
    ``before`` (C,) N, then ``after`` (C,) N from t = 0 for ``duration`` s, one row per
    ``control_timestep`` (``settled_rows`` rows before the step, at t < 0)."""
    before = np.asarray(before, float).reshape(1, -1)
    after = np.asarray(after, float).reshape(1, -1)
    backend.reset(before)
    dt = backend.control_timestep
    tip0 = backend.read().tip[0].copy()
    n = int(round(duration / dt))
    times = [-dt * k for k in range(settled_rows, 0, -1)] + [0.0]
    tips = [tip0] * settled_rows + [tip0]
    for k in range(1, n + 1):
        backend.apply_tensions(after)
        times.append(k * dt)
        tips.append(backend.read().tip[0].copy())
    return StepResponse(np.asarray(times), np.asarray(tips))


def run_step_fit(path: str | Path, out: str | Path | None = None, command: str = "") -> DampingFit:
    """``cdcr-gym calibrate --damping-step STEP.csv [--out DIR]``: fit, print the result and
    the backend argument, write ``DIR/damping.json`` (the fit and ``command``) if ``out``."""
    fit = fit_step_response(path)
    print(
        f"{Path(path).name}: {fit.n_rows} rows, step {1e3 * fit.amplitude_m:.3g} mm, "
        f"first mode {fit.frequency_hz:.4g} Hz, damping ratio {fit.damping_ratio:.4g} "
        f"(fit RMS {1e3 * fit.rms_m:.3g} mm)"
        + ("" if fit.well_posed else "; over-damped: only the slow decay rate is determined")
    )
    print(f"use: damping_ratio={fit.damping_ratio:.3g} (MuJoCoBackend, BulletBackend, make_env)")
    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        record = {"command": command, "data": str(path), **fit.to_dict()}
        (folder / "damping.json").write_text(json.dumps(record, indent=2) + "\n")
    return fit
