"""The outputs of a calibration: ``params.yaml`` (what envs read), ``report.md``, the
before/after residual figure and ``report.json`` (the numbers, :func:`report_json`), written
atomically (all four into a temporary folder first: nothing half-written on an error).

Error metrics (:func:`error_stats`), over a set of rows, in mm: ``rmse_aligned_mm`` is the RMSE
of the Euclidean tip error after subtracting the mean of (model − measured) over the set (the
metric published real-robot results use); ``mean_mm``, ``median_mm``, ``p95_mm`` are of the
plain Euclidean error.

``params.yaml`` holds the fitted robot under ``robot:`` (read by ``RobotParams.from_yaml`` and by
``gymnasium.make(id, params="params.yaml")``), the fitted backend arguments under ``backend:``
(friction, payload, gravity, base orientation: pass them to a physics env,
``gym.make("cdcr_gym/BulletReach-v0", params=path, **backend_kwargs_from_yaml(path))``), and a
``calibration:`` record (data, backend, values and 95 % intervals, residual medians; for
displacement data the tendon drive under ``calibration.tendons``, with the drives' tension cap,
backlash and softening, which :func:`twin_kwargs_from_yaml` hands to an env driven by
displacements).
"""

from __future__ import annotations

import datetime
import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from cdcr_gym.calibration.fit import CalibrationResult
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.params_yaml import dump_yaml, load_yaml, params_from_dict, params_to_dict

__all__ = [
    "write_params_yaml",
    "load_fitted",
    "backend_kwargs_from_yaml",
    "twin_kwargs_from_yaml",
    "report_markdown",
    "plot_residuals",
    "write_outputs",
    "display",
    "error_stats",
    "report_json",
    "REPORT_KEYS",
]

#: How a parameter is shown in reports: (unit, factor from SI).
_DISPLAY = {
    "youngs_modulus": ("GPa", 1e-9),
    "cable_radius": ("mm", 1e3),
    "base_x": ("mm", 1e3),
    "base_y": ("mm", 1e3),
    "base_z": ("mm", 1e3),
    "marker_offset": ("mm", 1e3),
    "friction_coefficient": ("", 1.0),
    "tip_payload": ("g", 1e3),
    "base_compliance": ("mm/kN", 1e6),
    "drive_backlash": ("mm", 1e3),
    "drive_softening": ("1/m", 1.0),
    "backbone_friction": ("mN·m", 1e3),
}


def error_stats(pred: np.ndarray, meas: np.ndarray) -> dict[str, Any]:
    """Tip error statistics (mm) of predictions (M, 3) m against measurements (M, 3) m
    (module docstring), plus the aligned RMSE along X, Y, Z and the mean offset (mm)."""
    err = np.asarray(pred, dtype=np.float64) - np.asarray(meas, dtype=np.float64)
    offset = err.mean(axis=0)
    aligned = err - offset
    plain = np.linalg.norm(err, axis=1) * 1e3
    return {
        "rmse_aligned_mm": float(np.sqrt(np.mean(np.sum(aligned**2, axis=1))) * 1e3),
        "mean_mm": float(plain.mean()),
        "median_mm": float(np.median(plain)),
        "p95_mm": float(np.percentile(plain, 95)),
        "rmse_aligned_xyz_mm": [float(v) for v in np.sqrt(np.mean(aligned**2, axis=0)) * 1e3],
        "mean_offset_mm": [float(v) for v in offset * 1e3],
    }


#: The keys of ``report.json`` (nested: ``train`` and ``validation`` are mappings).
REPORT_KEYS = {
    "train": ("rmse_aligned_mm", "mean_mm"),
    "validation": ("rmse_aligned_mm", "mean_mm", "median_mm", "p95_mm", "percent_of_length"),
    "backend": None,
    "fitted": None,
    "seconds": None,
}


def report_json(result: CalibrationResult) -> dict[str, Any]:
    """The ``report.json`` document: ``{"train": {"rmse_aligned_mm", "mean_mm"},
    "validation": {"rmse_aligned_mm", "mean_mm", "median_mm", "p95_mm", "percent_of_length"}
    (null without held-out data), "backend", "fitted" (name → SI value), "seconds"}`` — numbers
    in mm unless named; ``percent_of_length`` = validation mean / the fitted robot's length."""
    train = error_stats(result.after.tip, result.data.tip)
    validation = None
    if result.validation is not None and result.validation_data is not None:
        v = error_stats(result.validation.tip, result.validation_data.tip)
        validation = {k: v[k] for k in REPORT_KEYS["validation"] if k in v}  # type: ignore[union-attr]
        validation["percent_of_length"] = 100.0 * v["mean_mm"] * 1e-3 / result.params.length
    return {
        "train": {k: train[k] for k in REPORT_KEYS["train"]},  # type: ignore[union-attr]
        "validation": validation,
        "backend": result.backend,
        "fitted": {n: float(result.values[n]) for n in result.names},
        "seconds": float(result.seconds),
    }


def display(name: str) -> tuple[str, float]:
    """Display unit and factor of parameter ``name`` (angles in degrees)."""
    if name in _DISPLAY:
        return _DISPLAY[name]
    if name.startswith(("length_s", "cable_radius_s")):
        return ("mm", 1e3)
    if name.startswith("tendon_stiffness"):
        return ("N/m", 1.0)
    if name.startswith("tendon_pretension"):
        return ("N", 1.0)
    return ("°", 180.0 / math.pi)


def _plain(value: Any) -> Any:
    if isinstance(value, (np.floating, float)):
        return float(value)
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def write_params_yaml(result: CalibrationResult, path: str | Path, command: str = "") -> None:
    """Write ``params.yaml`` (module docstring)."""
    e0, e1 = result.errors_before, result.errors_after
    record = {
        "data": result.data.source,
        "points": len(result.data),
        "backend": result.backend,
        "fitted": {n: result.values[n] for n in result.names},
        "ci95": {
            n: (result.ci95[n] if math.isfinite(result.ci95[n]) else None) for n in result.names
        },
        "start": {n: result.start[n] for n in result.names},
        "median_tip_error_before_m": float(np.median(e0)),
        "median_tip_error_after_m": float(np.median(e1)),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    }
    if command:
        record["command"] = command
    if result.drive is not None:
        record["tendons"] = result.drive.to_dict()
    frame = {
        n: result.values[n]
        for n in ("base_x", "base_y", "base_z", "base_tilt_x", "base_tilt_y", "base_yaw")
        + ("marker_offset",)
        if n in result.values
    }
    if frame:
        record["frame"] = frame
    if result.validation is not None and result.validation_data is not None:
        record["validation"] = {
            "data": result.validation_data.source,
            "points": len(result.validation_data),
            **error_stats(result.validation.tip, result.validation_data.tip),
        }
    doc = {
        "robot": params_to_dict(result.params),
        "backend": _plain(result.backend_kwargs),
        "calibration": _plain(record),
    }
    header = (
        "# A robot fitted by cdcr-gym calibrate. Envs read it: gym.make(id, params=<this file>);\n"
        "# a physics env also takes the fitted backend arguments: "
        "cdcr_gym.calibration.backend_kwargs_from_yaml(<this file>).\n"
    )
    text = dump_yaml({k: v for k, v in doc.items() if v != {}})
    Path(path).write_text(header + text)


def load_fitted(path: str | Path) -> tuple[RobotParams, dict[str, Any]]:
    """The robot and the backend keyword arguments of a ``params.yaml``."""
    data = load_yaml(Path(path))
    params = params_from_dict(data, str(path))
    return params, backend_kwargs_from_yaml(path, data)


def backend_kwargs_from_yaml(path: str | Path, data: Any = None) -> dict[str, Any]:
    """The ``backend:`` mapping of a ``params.yaml`` (empty if none); ``base_orientation`` as a
    tuple."""
    data = load_yaml(Path(path)) if data is None else data
    kw = dict(data.get("backend") or {}) if isinstance(data, dict) else {}
    if "base_orientation" in kw:
        kw["base_orientation"] = tuple(kw["base_orientation"])
    return kw


def twin_kwargs_from_yaml(path: str | Path, action_mode: str = "displacement") -> dict[str, Any]:
    """Everything but the robot that rebuilds the calibrated model of a ``params.yaml`` as an
    env: ``gym.make(id, params=path, **twin_kwargs_from_yaml(path))``.

    The backend arguments (:func:`backend_kwargs_from_yaml`), ``action_mode``, and in a
    displacement action mode the fitted tendon drive's cap, backlash and softening from
    ``calibration.tendons`` (``drive_max_tension``: its ``max_tension``, ``inf`` — no cap — when
    it has none, as the calibration's replays; ``drive_backlash``: its ``backlash``, m;
    ``drive_softening``: its ``softening``, 1/m), so the env's drives act as the fitted ones did. A file without ``calibration.tendons`` (a fit to
    tensions, a hand-written robot) adds no drive arguments.

    Raises:
        ValueError: naming the file for a malformed ``calibration.tendons``.
    """
    from cdcr_gym.calibration.drive import TendonDrive

    data = load_yaml(Path(path))
    kw: dict[str, Any] = {**backend_kwargs_from_yaml(path, data), "action_mode": action_mode}
    cal = data.get("calibration") if isinstance(data, dict) else None
    tendons = cal.get("tendons") if isinstance(cal, dict) else None
    if action_mode in ("displacement", "displacement_delta") and isinstance(tendons, dict):
        params = params_from_dict(data, str(path))
        drive = TendonDrive.from_dict(tendons, params.n_cables, f"{path}: calibration.tendons")
        kw["drive_max_tension"] = float(drive.max_tension)
        if drive.backlash > 0.0:
            kw["drive_backlash"] = float(drive.backlash)
        if drive.softening > 0.0:
            kw["drive_softening"] = float(drive.softening)
    return kw


def _fmt(name: str, value: float) -> str:
    unit, factor = display(name)
    return f"{value * factor:.6g}"


#: Longest data set whose per-point table goes into report.md.
PER_POINT_ROWS = 300


def report_markdown(result: CalibrationResult, command: str = "", figure: str = "") -> str:
    """The Markdown report: parameters with 95 % intervals, residual statistics, per-point
    residuals before and after, notes."""
    e0, e1 = result.errors_before * 1e3, result.errors_after * 1e3
    out = ["# Calibration report", ""]
    if command:
        out += ["```", command, "```", ""]
    out += [
        f"Data: `{result.data.source}`, {len(result.data)} points; backend: **{result.backend}**"
        + (f" ({_plain(result.backend_kwargs)})" if result.backend_kwargs else "")
        + f"; {result.nfev} model evaluations in {result.seconds:.1f} s ({result.message})",
        "",
        "## Parameters",
        "",
        "| parameter | unit | start | fitted | ± 95 % CI | std. error |",
        "|---|---|---|---|---|---|",
    ]
    for n in result.names:
        unit, factor = display(n)
        ci = result.ci95[n]
        ci_text = f"{ci * factor:.3g}" if math.isfinite(ci) else "not identifiable"
        sd = result.std[n]
        sd_text = f"{sd * factor:.3g}" if math.isfinite(sd) else "—"
        out.append(
            f"| {n} | {unit} | {_fmt(n, result.start[n])} | {_fmt(n, result.values[n])} | "
            f"{ci_text} | {sd_text} |"
        )
    out += [
        "",
        f"Residual standard deviation s = {result.residual_sigma:.3g} × the rows' σ "
        "(the intervals use s²(JᵀJ)⁻¹).",
        "",
    ]
    if len(result.names) > 1:
        out += ["Correlations:", "", "| | " + " | ".join(result.names) + " |"]
        out.append("|---" * (len(result.names) + 1) + "|")
        for i, n in enumerate(result.names):
            row = " | ".join(f"{c:+.3f}" for c in result.correlation[i])
            out.append(f"| {n} | {row} |")
        out.append("")
    out += [
        "## Tip residuals (mm)",
        "",
        "| | median | mean | max |",
        "|---|---|---|---|",
        f"| before (start values) | {np.median(e0):.3f} | {e0.mean():.3f} | {e0.max():.3f} |",
        f"| after (fitted) | {np.median(e1):.3f} | {e1.mean():.3f} | {e1.max():.3f} |",
        "",
    ]
    stats = error_stats(result.after.tip, result.data.tip)
    rows = [("training (fitted)", stats, len(result.data))]
    if result.validation is not None and result.validation_data is not None:
        v = error_stats(result.validation.tip, result.validation_data.tip)
        rows.append((f"held-out `{result.validation_data.source}`", v, len(result.validation_data)))
    out += [
        "Aligned RMSE: the Euclidean tip RMSE after subtracting the mean of (model − measured) "
        "over the set; X/Y/Z: its components.",
        "",
        "| set | rows | aligned RMSE | mean | median | p95 | aligned X / Y / Z | % of length (mean) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, st, n_rows in rows:
        xyz = " / ".join(f"{c:.2f}" for c in st["rmse_aligned_xyz_mm"])
        pct = 100.0 * st["mean_mm"] * 1e-3 / result.params.length
        out.append(
            f"| {label} | {n_rows} | {st['rmse_aligned_mm']:.3f} | {st['mean_mm']:.3f} | "
            f"{st['median_mm']:.3f} | {st['p95_mm']:.3f} | {xyz} | {pct:.2f} |"
        )
    out.append("")
    if figure:
        out += [f"![residuals]({figure})", ""]
    if result.notes or result.unsettled > 1e-6:
        out += ["## Notes", ""]
        out += [f"- {n}" for n in result.notes]
        if result.unsettled > 1e-6 and result.data.displacements is not None:
            out.append(
                f"- the replayed robot moved by up to {result.unsettled * 1e3:.3g} mm in the "
                "control step before a row's time: the replay follows the recorded timing, "
                "so a row taken during a fast motion is read while moving (as on the robot)"
            )
        elif result.unsettled > 1e-6:
            out.append(
                f"- the physics replay was still moving by {result.unsettled * 1e3:.3g} mm per "
                "control step at some rows: raise --settle-steps"
            )
        out.append("")
    words = {1: "up", -1: "down", 0: ""}
    d = result.data
    disp = d.displacements is not None
    if len(d) > PER_POINT_ROWS:
        out += [f"(Per-point table left out: {len(d)} rows > {PER_POINT_ROWS}.)", ""]
        return "\n".join(out) + "\n"
    cables = [f"d{i + 1} (mm)" if disp else f"T{i + 1} (N)" for i in range(result.data.n_cables)]
    out += [
        "## Per point",
        "",
        "| line | " + " | ".join(cables) + " | direction | before (mm) | after (mm) |",
        "|---" * (len(cables) + 4) + "|",
    ]
    for k in range(len(d)):
        ts = " | ".join(f"{t * (1e3 if disp else 1.0):.4g}" for t in d.commands[k])
        out.append(
            f"| {d.lines[k]} | {ts} | {words[int(d.direction[k])]} | {e0[k]:.3f} | {e1[k]:.3f} |"
        )
    return "\n".join(out) + "\n"


def plot_residuals(result: CalibrationResult, path: str | Path, title: str = "") -> None:
    """Before/after figure: the tip's distance from the axis against the load, rows in order
    (left: loading and unloading branches), and the per-point errors (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = result.data
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.4))
    up = d.direction >= 0

    def radial(p: np.ndarray) -> np.ndarray:
        return np.hypot(p[:, 0], p[:, 1]) * 1e3

    if d.displacements is not None:
        _plot_displacement(result, fig, ax0, ax1, title)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return
    load = d.commands.sum(axis=1)
    for pts, style, label in (
        (d.tip, dict(color="k", marker="o", ms=5, ls="none", mfc="none"), "measured"),
        (result.before.tip, dict(color="tab:red", marker="x", ms=4, lw=0.6), "start values"),
        (result.after.tip, dict(color="tab:blue", marker="+", ms=6, lw=0.6), "fitted"),
    ):
        ax0.plot(load, radial(pts), label=label, **style)  # type: ignore[arg-type]
    ax0.set_xlabel(
        "total tendon displacement (mm)"
        if d.displacements is not None
        else "total cable tension (N), rows in order"
    )
    ax0.set_ylabel("tip distance from the axis √(x²+y²) (mm)")
    ax0.grid(alpha=0.3)
    ax0.legend()
    idx = np.arange(len(d))
    e0, e1 = result.errors_before * 1e3, result.errors_after * 1e3
    ax1.semilogy(idx, np.maximum(e0, 1e-4), "x-", color="tab:red", ms=4, lw=0.8, label="start")
    ax1.semilogy(idx, np.maximum(e1, 1e-4), "+-", color="tab:blue", ms=6, lw=0.8, label="fitted")
    ax1.plot(
        idx[~up],
        np.maximum(e1[~up], 1e-4),
        "s",
        mfc="none",
        color="tab:blue",
        ms=6,
        label="unloading rows",
    )
    ax1.set_xlabel("measurement (in order)")
    ax1.set_ylabel("tip error (mm)")
    ax1.grid(alpha=0.3, which="both")
    ax1.legend()
    fig.suptitle(
        title
        or f"{d.source}, {result.backend}: median error {np.median(e0):.3g} → {np.median(e1):.3g} mm"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_displacement(result: CalibrationResult, fig: Any, ax0: Any, ax1: Any, title: str) -> None:
    """Displacement data: predicted against measured tip coordinates (left, training and
    held-out rows) and the per-row errors in order (right)."""
    d = result.data
    sets = [("train", result.after.tip, d.tip, "tab:blue")]
    if result.validation is not None and result.validation_data is not None:
        sets.append(("held out", result.validation.tip, result.validation_data.tip, "tab:orange"))
    lo, hi = np.inf, -np.inf
    for label, pred, meas, color in sets:
        for axis, marker in zip("xyz", ("o", "s", "^")):
            k = "xyz".index(axis)
            ax0.plot(
                meas[:, k] * 1e3,
                pred[:, k] * 1e3,
                marker,
                ms=2,
                alpha=0.4,
                color=color,
                label=f"{label} {axis}",
            )
        lo, hi = min(lo, meas.min() * 1e3), max(hi, meas.max() * 1e3)
    ax0.plot([lo, hi], [lo, hi], "k-", lw=0.6)
    ax0.set_xlabel("measured tip coordinate (mm)")
    ax0.set_ylabel("fitted model (mm)")
    ax0.grid(alpha=0.3)
    ax0.legend(fontsize=7, ncol=2, markerscale=3)
    start = 0
    for label, pred, meas, color in sets:
        err = np.linalg.norm(pred - meas, axis=1) * 1e3
        idx = np.arange(start, start + len(err))
        ax1.semilogy(idx, np.maximum(err, 1e-3), ".", ms=2, color=color, label=label)
        start += len(err)
    e0 = result.errors_before * 1e3
    ax1.semilogy(
        np.arange(len(e0)), np.maximum(e0, 1e-3), ".", ms=1, color="0.7", label="train, start"
    )
    ax1.set_xlabel("row (training rows, then held-out rows; in order)")
    ax1.set_ylabel("Euclidean tip error (mm)")
    ax1.grid(alpha=0.3, which="both")
    ax1.legend(fontsize=8, markerscale=4)
    doc = report_json(result)
    text = f"train aligned RMSE {doc['train']['rmse_aligned_mm']:.2f} mm"
    if doc["validation"] is not None:
        text += f", held-out {doc['validation']['rmse_aligned_mm']:.2f} mm"
    fig.suptitle(title or f"{d.source}, {result.backend}: {text}")


def write_outputs(result: CalibrationResult, out: str | Path, command: str = "") -> dict[str, Path]:
    """Write ``params.yaml``, ``report.md``, ``residuals.png`` and ``report.json`` into
    ``out`` (atomically: all four are written into a temporary folder beside it, which is then
    renamed to ``out``; into an existing ``out`` each is moved by an atomic rename, other files
    there stay); their paths."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    names = {
        "params": "params.yaml",
        "report": "report.md",
        "figure": "residuals.png",
        "json": "report.json",
    }
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        write_params_yaml(result, tmp / names["params"], command)
        plot_residuals(result, tmp / names["figure"])
        (tmp / names["report"]).write_text(report_markdown(result, command, "residuals.png"))
        doc = report_json(result)
        (tmp / names["json"]).write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
        if out.exists():
            # every file complete before any is moved in; other files in ``out`` stay
            for name in names.values():
                os.replace(tmp / name, out / name)
            tmp.rmdir()
        else:
            os.rename(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return {k: out / v for k, v in names.items()}
