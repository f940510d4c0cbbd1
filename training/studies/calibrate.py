"""``cdcr-gym calibrate``: fit robot parameters to measured tip positions.

    cdcr-gym calibrate DATA.csv --robot paper --backend bullet --fit E,mu,payload --out DIR
    cdcr-gym calibrate train.csv --robot ftdcr_v4 --backend ccka --validate val.csv \
        --fit base_frame,marker,k_tendons,T0_tendons,cable_angles --out DIR
    cdcr-gym calibrate train.csv --robot DIR/params.yaml --start-from DIR/params.yaml \
        --backend mujoco --validate val.csv --fit base_frame,marker,E,payload --out DIR2

writes ``DIR/params.yaml`` (the fitted robot, which every env reads:
``gym.make(id, params="DIR/params.yaml")``, and the fitted backend arguments), ``DIR/report.md``
(parameters with 95 % confidence intervals, residuals per point before/after) and
``DIR/residuals.png`` and ``DIR/report.json`` (train/held-out error numbers). The CSV format and the fit are documented in
:mod:`cdcr_gym.calibration` and ``docs/calibration.md``.

``cdcr-gym calibrate --synthetic-study --out docs/figures/calibration`` runs the
validation study instead: measurements generated on a physics backend with known perturbed
parameters (E −20 %, cable radius +0.5 mm, μ = 0.15, 20 g payload, gravity on; cable 1 loaded
0 → 8 kg → 0 in 0.5 kg steps, as in the paper) plus FARO-like and coarse noise (σ = 0.02 mm and
0.5 mm), then fitted on the physics backend and on the analytic model alone
(``study.json``, ``study.png``, the generated CSVs).
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from training.run.argtypes import non_negative_int, positive_float, positive_int
from training.run.config import ConfigError, check_writable_directory

__all__ = ["main", "build_parser", "synthetic_study", "ablation_table", "DEFAULT_BACKEND_ARGS"]

#: Backend arguments a calibration uses unless overridden with ``--backend-arg``.
#: ``friction_slip_length`` 2 mm: with the backends' default 0.1 mm the unloading branch of a
#: 0–80 N sweep with μ = 0.15 never settles (the slip state of the loaded cable flips between ±1
#: every step: ≈ 1 mm (bullet, 10 ms steps) and 3 mm (MuJoCo, 20 ms) of tip motion per control
#: step, indefinitely); with 2 mm the stick phase after a reversal settles.
DEFAULT_BACKEND_ARGS: dict[str, dict[str, Any]] = {
    "bullet": {"gravity": True, "friction_slip_length": 2e-3},
    "mujoco": {"gravity": True, "friction_slip_length": 2e-3},
    "analytic": {},
}

#: The study's true perturbation of the paper robot.
STUDY_TRUTH = {
    "youngs_modulus": 0.8 * 35e9,
    "cable_radius": 0.029 + 0.0005,
    "friction_coefficient": 0.15,
    "tip_payload": 0.020,
}


def _value(text: str) -> Any:
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        pass
    if "," in text:
        return tuple(_value(t) for t in text.split(","))
    return text


def _backend_args(items: list[str], backend: str) -> dict[str, Any]:
    kw = dict(DEFAULT_BACKEND_ARGS.get(backend, {}))
    for item in items:
        if "=" not in item:
            raise ValueError(f"--backend-arg must be KEY=VALUE, got {item!r}")
        key, text = item.split("=", 1)
        kw[key.strip()] = _value(text.strip())
    return kw


def _start(items: list[str]) -> dict[str, float]:
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--start must be NAME=VALUE (SI units), got {item!r}")
        key, text = item.split("=", 1)
        try:
            out[key.strip()] = float(text)
        except ValueError:
            raise ValueError(f"--start {key}: {text!r} is not a number") from None
    return out


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``cdcr-gym calibrate``."""
    p = argparse.ArgumentParser(
        prog="cdcr-gym calibrate",
        description="Fit robot parameters (stiffness, friction, cable offsets, payload, base "
        "tilt) to measured tip positions; writes params.yaml, report.md and residuals.png.",
    )
    p.add_argument(
        "data",
        nargs="?",
        type=Path,
        help="measurement file: this package's CSV (T/m/d columns) or the published format "
        "(timestamp, pattern_label, servo_<id>_mm..., tip_x, tip_y, tip_z; mm) "
        "(docs/calibration.md)",
    )
    p.add_argument(
        "--format",
        default="auto",
        choices=("auto", "cdcr", "published"),
        help="measurement file format (default: auto, from the header)",
    )
    p.add_argument(
        "--validate",
        type=Path,
        metavar="VAL.csv",
        help="held-out measurements (same format rules): replayed with the fitted model after "
        "the fit, never fitted; their errors go into report.json/report.md",
    )
    p.add_argument(
        "--linear-law",
        action="store_true",
        help="ablation: the drive law without slack (T = T0 + k(d - s), may go negative)",
    )
    p.add_argument(
        "--stiffness-scale",
        type=positive_float,
        default=1.0,
        help="ablation: multiply every tendon stiffness (e.g. 1000: the rigid-tendon limit)",
    )
    p.add_argument(
        "--robot",
        default="paper",
        help="preset name (paper, tdcr2, ftdcr_v4, ...) or a params YAML file to start from "
        "(default: paper); --params is the same",
    )
    p.add_argument("--params", dest="robot", help=argparse.SUPPRESS)
    p.add_argument(
        "--backend",
        default="analytic",
        choices=("analytic", "ccka", "bullet", "mujoco"),
        help="model to fit: ccka (= analytic: CCKA/PCC, fast, no gravity/friction; tension or "
        "displacement data) or a physics backend replayed through the rows in order "
        "(tension data; displacement data with their recorded timing) (default: analytic)",
    )
    p.add_argument(
        "--fit",
        default="E",
        help="comma-separated parameters (SI units; i = tendon 1..C, j = section 1..S): "
        "youngs_modulus (E); cable_radius (r, all sections), cable_radius_s<j> (cable_radii); "
        "cable_angle_<i> (cable_angles), section_angle_s<j> (section_angles); length_s<j> "
        "(lengths); base_x, base_y, base_z (base_translation), base_tilt_x, base_tilt_y "
        "(tilt), base_yaw (base_rotation = tilt + yaw; base_frame = translation + rotation); "
        "marker_offset (marker, along the tip tangent); tendon_stiffness (k), "
        "tendon_stiffness_s<j> (k_sections), tendon_stiffness_<i> (k_tendons); "
        "tendon_pretension (T0), tendon_pretension_s<j> (T0_sections), tendon_pretension_<i> "
        "(T0_tendons); physics only: friction_coefficient (mu), tip_payload (payload). "
        "Ill-posed pairs are pinned and reported: base_yaw with every tendon angle free pins "
        "the first angle; E with every k and T0 free pins E (default: E)",
    )
    p.add_argument("--out", type=Path, help="output directory (created; must be writable)")
    p.add_argument(
        "--backend-arg",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="fixed backend argument, repeatable (e.g. gravity=false, links_per_span=4); "
        "bullet defaults: gravity=true friction_slip_length=0.002",
    )
    p.add_argument(
        "--start",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="start value of a fitted parameter in SI units (the names and aliases of --fit; "
        "an alias sets every parameter it covers), repeatable",
    )
    p.add_argument(
        "--start-from",
        type=Path,
        default=None,
        metavar="PARAMS.yaml",
        help="start values of the fitted parameters from a fit's params.yaml (its "
        "calibration.fitted; warm start, e.g. a physics fit from the CCKA fit); --start wins",
    )
    p.add_argument(
        "--max-gap",
        type=float,
        default=1.0,
        help="physics replay of displacement data: longest gap (s) between rows simulated "
        "(longer pauses are shortened to it)",
    )
    p.add_argument(
        "--ramp-steps", type=positive_int, default=25, help="physics replay: ramp steps per row"
    )
    p.add_argument(
        "--settle-steps",
        type=non_negative_int,
        default=50,
        help="physics replay: settle steps per row",
    )
    p.add_argument(
        "--max-evals", type=positive_int, default=None, help="limit on least_squares steps (nfev)"
    )
    p.add_argument("--quiet", action="store_true", help="no per-evaluation progress")
    p.add_argument(
        "--ablation-table",
        type=Path,
        metavar="DIR",
        help="collect DIR/params.yaml and DIR/ablation/*/params.yaml into DIR/ablation.md and "
        "DIR/ablation.json (held-out errors of each variant) instead of fitting",
    )
    p.add_argument(
        "--synthetic-study",
        action="store_true",
        help="run the validation study on synthetic measurements instead (DATA not used)",
    )
    p.add_argument(
        "--study-backend",
        default="mujoco",
        choices=("bullet", "mujoco"),
        help="physics backend that generates and fits the study's data (default: mujoco)",
    )
    p.add_argument(
        "--damping-step",
        type=Path,
        metavar="STEP.csv",
        help="fit the damping ratio ζ and first-mode frequency to a recorded step response "
        "(columns t, x, y, z; step at t = 0) instead; prints damping_ratio for the backends "
        "and writes OUT/damping.json if --out is given",
    )
    return p


def _check_writable(out: Path) -> None:
    """ValueError unless ``out`` is, or can be created as, a writable directory; nothing is
    created here (the results are written all at once at the end, or not at all)."""
    try:
        check_writable_directory(out, "--out")
    except ConfigError as exc:
        raise ValueError(str(exc)) from None


def _start_from(path: Path, robot, fit: str) -> dict[str, float]:
    """The values of ``path``'s calibration.fitted among the parameters of ``fit``."""
    from cdcr_gym.calibration.parameters import expand_names
    from cdcr_gym.model.params_yaml import load_yaml

    data = load_yaml(path)
    fitted = (data.get("calibration") or {}).get("fitted") if isinstance(data, dict) else None
    if not isinstance(fitted, dict):
        raise ValueError(f"--start-from {str(path)!r}: no calibration.fitted mapping")
    wanted = set(expand_names(fit, robot))
    return {k: float(v) for k, v in fitted.items() if k in wanted}


def _drive(text: str, robot):
    """The robot's tendon drive (``TendonDrive.of``) with what a fitted params YAML keeps
    beside the robot in ``calibration.tendons``: the drives' backlash and tension cap."""
    from dataclasses import replace

    from cdcr_gym.calibration.drive import TendonDrive
    from cdcr_gym.model.params_yaml import load_yaml

    drive = TendonDrive.of(robot)
    if drive is None or Path(text).suffix not in (".yaml", ".yml"):
        return drive
    data = load_yaml(Path(text))
    tendons = ((data.get("calibration") or {}).get("tendons")) if isinstance(data, dict) else None
    if not isinstance(tendons, dict):
        return drive
    kept = TendonDrive.from_dict(tendons, robot.n_cables, f"{text}: calibration.tendons")
    return replace(drive, backlash=kept.backlash, max_tension=kept.max_tension)


def _robot(text: str):
    from cdcr_gym.model.params import PRESETS, RobotParams

    if text in PRESETS:
        return RobotParams.preset(text)
    if Path(text).suffix in (".yaml", ".yml"):
        return RobotParams.from_yaml(Path(text))
    raise ValueError(
        f"--robot must be a preset {sorted(PRESETS)} or a .yaml params file, got {text!r}"
    )


def main(argv: list[str] | None = None) -> int:
    """Run ``cdcr-gym calibrate`` (see the module docstring); returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    command = "cdcr-gym calibrate " + " ".join(
        shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)
    )
    if args.ablation_table is not None:
        try:
            ablation_table(args.ablation_table)
        except ValueError as exc:
            parser.error(str(exc))
        return 0
    if args.damping_step is not None:
        from cdcr_gym.calibration.damping import run_step_fit

        try:
            run_step_fit(args.damping_step, args.out, command)
        except ValueError as exc:
            parser.error(str(exc))
        return 0
    if args.out is None:
        parser.error("--out DIR is required")
    try:
        _check_writable(args.out)
    except ValueError as exc:
        parser.error(str(exc))
    if args.synthetic_study:
        synthetic_study(args.out, args.study_backend, command=command, verbose=not args.quiet)
        return 0
    if args.data is None:
        parser.error("DATA.csv is required (or --synthetic-study)")
    from cdcr_gym.calibration import calibrate, read_csv, write_outputs

    try:
        robot = _robot(args.robot)
        drive = _drive(args.robot, robot)
        data = read_csv(args.data, args.format, robot, drive)
        validate = read_csv(args.validate, args.format, robot, drive) if args.validate else None
        kwargs = _backend_args(args.backend_arg, args.backend)
        start = _start(args.start)
        if args.start_from is not None:
            start = {**_start_from(args.start_from, robot, args.fit), **start}
        if not (math.isfinite(args.max_gap) and args.max_gap > 0):
            raise ValueError(f"--max-gap must be > 0 s, got {args.max_gap!r}")
        if not (math.isfinite(args.stiffness_scale) and args.stiffness_scale > 0):
            raise ValueError(f"--stiffness-scale must be > 0, got {args.stiffness_scale!r}")
        result = calibrate(
            data,
            robot,
            args.fit,
            args.backend,
            kwargs,
            start,
            ramp_steps=args.ramp_steps,
            settle_steps=args.settle_steps,
            max_nfev=args.max_evals,
            progress=None if args.quiet else print,
            drive=drive,
            validate=validate,
            slack=not args.linear_law,
            stiffness_scale=args.stiffness_scale,
            replay_options={"max_gap": args.max_gap},
        )
    except ValueError as exc:
        parser.error(str(exc))
    try:
        paths = write_outputs(result, args.out, command)
    except OSError as exc:  # a full disk, a directory made read-only meanwhile: nothing written
        where = f"{exc.filename}: " if exc.filename else ""
        print(
            f"cdcr-gym calibrate: error: --out {str(args.out)!r}: cannot write the results "
            f"({where}{exc.strerror or exc}); nothing was written",
            file=sys.stderr,
        )
        return 2
    _print_summary(result)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0


def _print_summary(result) -> None:
    from cdcr_gym.calibration.report import display

    for n in result.names:
        unit, f = display(n)
        ci = result.ci95[n]
        ci_text = f"± {ci * f:.3g}" if math.isfinite(ci) else "(not identifiable)"
        print(f"{n:>22s} = {result.values[n] * f:.6g} {ci_text} {unit}")
    e0, e1 = result.errors_before * 1e3, result.errors_after * 1e3
    print(f"median tip error: {np.median(e0):.3f} mm -> {np.median(e1):.4f} mm")
    from cdcr_gym.calibration.report import report_json

    doc = report_json(result)
    print(f"train: {doc['train']}")
    if doc["validation"] is not None:
        print(f"validation: {doc['validation']}")
    for note in result.notes:
        print(f"note: {note}")


#: What each ablation variant changes (ablation_table).
ABLATIONS = {
    ".": "full model: compliant one-sided tendons, base frame fitted",
    "rigid_tendons": "rigid tendons (k x 1000 of nominal, not fitted; no base compliance)",
    "no_slack": "no slack: the linear law T = T0 + k(d - s)",
    "no_base_frame": "no base-frame fit (robot base = measurement frame)",
    "rigid_base": "rigid base (no base compliance)",
    "no_backlash": "no drive backlash",
    "parallel_routing": "tendons parallel to the backbone (no helical pitch)",
}


def ablation_table(folder: Path) -> dict[str, Any]:
    """Collect the held-out errors of ``folder/params.yaml`` and ``folder/ablation/<name>/``
    into ``ablation.json`` and ``ablation.md`` in ``folder``; returns the rows."""
    from cdcr_gym.model.params_yaml import load_yaml

    folder = Path(folder)
    rows: dict[str, Any] = {}
    for name in ABLATIONS:
        path = folder / ("" if name == "." else f"ablation/{name}") / "params.yaml"
        if not path.is_file():
            continue
        cal = load_yaml(path)["calibration"]
        val = cal.get("validation")
        if val is None:
            raise ValueError(f"{path} has no validation record (run with --validate)")
        length = sum(s["length"] for s in load_yaml(path)["robot"]["sections"])
        rows["full" if name == "." else name] = {
            "what": ABLATIONS[name],
            "fitted": len(cal["fitted"]),
            "rmse_aligned_mm": val["rmse_aligned_mm"],
            "rmse_aligned_xyz_mm": val["rmse_aligned_xyz_mm"],
            "mean_mm": val["mean_mm"],
            "percent_of_length": 100.0 * val["mean_mm"] * 1e-3 / length,
            "command": cal.get("command", ""),
        }
    if not rows:
        raise ValueError(f"--ablation-table: no params.yaml under {str(folder)!r}")
    (folder / "ablation.json").write_text(json.dumps(rows, indent=1) + "\n")
    lines = [
        "# CCKA ablation on the held-out rows",
        "",
        "Aligned RMSE: Euclidean tip RMSE after removing the mean offset over the held-out set "
        "(mm); X / Y / Z its components; % of length: the plain mean error over the robot's "
        "length.",
        "",
        "| variant | fitted parameters | aligned RMSE | X / Y / Z | mean | % of length |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows.values():
        xyz = " / ".join(f"{v:.2f}" for v in r["rmse_aligned_xyz_mm"])
        lines.append(
            f"| {r['what']} | {r['fitted']} | {r['rmse_aligned_mm']:.2f} | {xyz} | "
            f"{r['mean_mm']:.2f} | {r['percent_of_length']:.2f} |"
        )
    lines += ["", "Commands:", ""] + [f"- `{r['command']}`" for r in rows.values()]
    (folder / "ablation.md").write_text("\n".join(lines) + "\n")
    return rows


# -- the validation study ---------------------------------------------------------------------------


def study_loads() -> np.ndarray:
    """The paper's protocol: 0 → 8 kg → 0 on cable 1 in 0.5 kg steps, as masses (kg), (33,)."""
    up = np.arange(0.0, 8.0 + 1e-9, 0.5)
    return np.concatenate([up, up[-2::-1]])


def generate(
    backend: str,
    truth: dict[str, float],
    sigma: float,
    seed: int,
    settle_steps: int = 200,
):
    """Synthetic measurements: the study protocol replayed on ``backend`` with the parameters
    ``truth`` (slow settling), plus Gaussian tip noise of standard deviation ``sigma`` (m)."""
    from cdcr_gym.calibration import Measurements
    from cdcr_gym.calibration.simulate import BackendReplay
    from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams

    masses = study_loads()
    tensions = np.stack([masses * STANDARD_GRAVITY, 0 * masses, 0 * masses], axis=1)
    direction = np.sign(np.diff(masses, prepend=-1.0)).astype(int)
    template = Measurements(tensions, np.zeros((len(masses), 3)), direction, None)
    replay = BackendReplay(
        template, RobotParams(), backend, DEFAULT_BACKEND_ARGS[backend], 25, settle_steps
    )
    clean = replay(truth).tip
    rng = np.random.default_rng(seed)
    noisy = clean + rng.normal(0.0, sigma, clean.shape)
    return Measurements(
        tensions,
        noisy,
        direction,
        np.full(len(masses), sigma),
        source=f"synthetic_sigma{sigma * 1e3:g}mm.csv",
    ), clean


def synthetic_study(
    out: Path, backend: str = "mujoco", *, command: str = "", verbose: bool = True
) -> dict[str, Any]:
    """The validation study (module docstring); writes ``study.json``, ``study.png``, the CSVs
    and a report per fit into ``out``; returns the summary."""
    from cdcr_gym.calibration import calibrate, write_csv, write_outputs
    from cdcr_gym.model.params import RobotParams

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    log = print if verbose else (lambda *a, **k: None)
    summary: dict[str, Any] = {
        "command": command,
        "backend": backend,
        "backend_args": DEFAULT_BACKEND_ARGS[backend],
        "truth": STUDY_TRUTH,
        "protocol": "cable 1: 0 -> 8 kg -> 0 in 0.5 kg steps (33 rows), each ramped over 25 "
        "control steps; data settled 200 steps, fits 50",
        "runs": {},
    }
    t_all = time.perf_counter()
    results = {}
    for sigma in (2e-5, 5e-4):
        t0 = time.perf_counter()
        data, clean = generate(backend, STUDY_TRUTH, sigma, seed=int(sigma * 1e6))
        log(f"generated sigma = {sigma * 1e3:g} mm in {time.perf_counter() - t0:.1f} s")
        write_csv(
            out / data.source,
            data,
            f"synthetic: paper robot on {backend}, truth {STUDY_TRUTH}, noise sigma {sigma} m",
        )
        fits: dict[str, tuple[str, dict[str, float]]] = {
            backend: ("E,r,mu,payload", {}),
            "analytic": ("E", {}),
            "analytic_tilt": ("E,tilt", {}),
        }
        for label, (names, start) in fits.items():
            name = backend if label == backend else "analytic"
            kw = DEFAULT_BACKEND_ARGS[name]
            log(f"fit {label} ({names}) on sigma = {sigma * 1e3:g} mm ...")
            res = calibrate(
                data,
                RobotParams(),
                names,
                name,
                kw,
                start,
                settle_steps=50,
                progress=(lambda s: log(s)) if name != "analytic" else None,
            )
            key = f"sigma_{sigma * 1e3:g}mm/{label}"
            results[key] = (res, clean)
            write_outputs(res, out / key.replace("/", "_"), command)
            e0, e1 = res.errors_before * 1e3, res.errors_after * 1e3
            # the fitted model against the noise-free tips (the measurements minus their noise):
            # with σ = 0.5 mm the residual against the data cannot fall below the noise
            # (median |noise| ≈ 1.54 σ in 3-D), the model error can
            true0 = np.linalg.norm(res.before.tip - clean, axis=1) * 1e3
            true1 = np.linalg.norm(res.after.tip - clean, axis=1) * 1e3
            run: dict[str, Any] = {
                "fitted": res.values,
                "ci95": {k: (v if math.isfinite(v) else None) for k, v in res.ci95.items()},
                "median_error_before_mm": float(np.median(e0)),
                "median_error_after_mm": float(np.median(e1)),
                "max_error_after_mm": float(np.max(e1)),
                "median_model_error_before_mm": float(np.median(true0)),
                "median_model_error_after_mm": float(np.median(true1)),
                "max_model_error_after_mm": float(np.max(true1)),
                "median_noise_mm": float(np.median(np.linalg.norm(data.tip - clean, axis=1)) * 1e3),
                "model_evaluations": res.nfev,
                "seconds": res.seconds,
            }
            if label == backend:
                run["checks"] = {
                    "E_rel_error": res.values["youngs_modulus"] / STUDY_TRUTH["youngs_modulus"] - 1,
                    "mu_error": res.values["friction_coefficient"]
                    - STUDY_TRUTH["friction_coefficient"],
                    "payload_error_g": 1e3
                    * (res.values["tip_payload"] - STUDY_TRUTH["tip_payload"]),
                    "cable_radius_error_mm": 1e3
                    * (res.values["cable_radius"] - STUDY_TRUTH["cable_radius"]),
                }
                c = run["checks"]
                run["pass"] = bool(
                    abs(c["E_rel_error"]) < 0.02
                    and abs(c["mu_error"]) < 0.03
                    and abs(c["payload_error_g"]) < 5
                    and run["median_model_error_after_mm"] < 0.5
                )
            summary["runs"][key] = run
            log(json.dumps({key: run}, default=float)[:600])
    summary["seconds"] = time.perf_counter() - t_all
    (out / "study.json").write_text(json.dumps(summary, indent=1, default=float))
    _plot_study(results, out / "study.png")
    return summary


def _plot_study(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = list(results)
    sigmas = sorted({k.split("/")[0] for k in keys})
    fig, axes = plt.subplots(1, len(sigmas), figsize=(6 * len(sigmas), 4.4), squeeze=False)
    for ax, sig in zip(axes[0], sigmas):
        first = True
        for k in keys:
            if not k.startswith(sig + "/"):
                continue
            res, clean = results[k]
            label = k.split("/")[1]
            idx = np.arange(len(res.data))
            if first:
                ax.semilogy(idx, res.errors_before * 1e3, "k:", label="nominal robot (start)")
                first = False
            if label not in ("analytic", "analytic_tilt"):
                model = np.linalg.norm(res.after.tip - clean, axis=1) * 1e3
                ax.semilogy(
                    idx,
                    np.maximum(model, 1e-4),
                    "--",
                    color="tab:blue",
                    lw=1,
                    label=f"fitted on {label} vs noise-free tips: median {np.median(model):.3g} mm",
                )
            ax.semilogy(
                idx,
                np.maximum(res.errors_after * 1e3, 1e-4),
                marker=".",
                lw=1,
                label=f"fitted on {label}: median {np.median(res.errors_after) * 1e3:.3g} mm",
            )
        ax.axvline(16, color="0.6", lw=0.8)
        ax.text(16.3, ax.get_ylim()[1] * 0.5, "unloading →", fontsize=8, color="0.4")
        ax.set_title(f"synthetic data, noise {sig.replace('sigma_', 'σ = ')}")
        ax.set_xlabel("measurement (0 → 8 kg → 0 on cable 1, 0.5 kg steps)")
        ax.set_ylabel("tip error (mm)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
