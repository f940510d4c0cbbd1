"""``cdcr-gym reproduce`` (``python -m training.studies.reproduce``): the study's command line."""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from cdcr_gym.model.params import RobotParams
from training.run.argtypes import int_at_least, positive_float, positive_int
from training.studies.reproduce import report
from training.studies.reproduce.outputs import summary_rows, write_outputs
from training.studies.reproduce.study import (
    DEFAULT_OUT,
    FACTORIES,
    BackendFactory,
    SettleError,
    StudyConfig,
    run_study,
)

#: ``--backend`` default: MuJoCo, the package's reference physics (within 0.2 % of ℓ of a
#: converged Cosserat rod at its default one link per span; docs/mujoco_backend.md). pybullet
#: (``--backend bullet``, 4 links per span by default) is the study's first backbone.
DEFAULT_BACKEND = "mujoco"
#: ``--links-per-span`` default per backend: each backend's converged-enough main sweeps
#: (MuJoCo: its env default, 1 with the corrected routing; pybullet: 4, converged beyond its
#: one-link default, which is within 0.44 % of ℓ; docs/bullet_backend.md).
DEFAULT_LINKS_PER_SPAN = {"mujoco": 1, "bullet": 4}


# ---------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------
def quick_config(**overrides) -> StudyConfig:
    """A coarse grid for smoke tests: 5 forces, 2 payloads, 2 resolutions, 2 disk counts."""
    base = dict(
        forces=(0.0, 20.0, 40.0, 60.0, 80.0),
        n_dl=11,
        payloads=(0.0, 0.2),
        n_disks_values=(5, 9),
        links_per_span_values=(1, 4),
        resolution_forces=(0.0, 40.0, 80.0),
    )
    base.update(overrides)
    return StudyConfig(**base)


def _float_list(name: str, lo: float = 0.0) -> Callable[[str], tuple[float, ...]]:
    def parse(text: str) -> tuple[float, ...]:
        try:
            vals = tuple(float(x) for x in text.split(",") if x.strip() != "")
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{name} must be comma-separated numbers, got {text!r}"
            ) from None
        if not vals or any(not math.isfinite(v) or v < lo for v in vals):
            raise argparse.ArgumentTypeError(f"{name} must be finite values >= {lo}, got {text!r}")
        if any(b <= a for a, b in zip(vals, vals[1:])):
            raise argparse.ArgumentTypeError(f"{name} must increase strictly, got {text!r}")
        return vals

    return parse


def _int_list(name: str) -> Callable[[str], tuple[int, ...]]:
    def parse(text: str) -> tuple[int, ...]:
        try:
            vals = tuple(int(x) for x in text.split(",") if x.strip() != "")
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{name} must be comma-separated integers, got {text!r}"
            ) from None
        if not vals or any(v < 1 for v in vals):
            raise argparse.ArgumentTypeError(f"{name} must be integers >= 1, got {text!r}")
        return vals

    return parse


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="cdcr-gym reproduce",
        description="Reproduce the paper's CCKA-vs-simulation study (section 4) with a physics "
        "backbone (MuJoCo by default, or pybullet), and extend it (gravity, tip payload, model resolution, horizontal base). "
        "Writes PNG figures, CSV data, report.md and run.json into --out.",
    )
    ap.add_argument(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        help=f"output folder (created; default: {DEFAULT_OUT})",
    )
    ap.add_argument(
        "--backend",
        choices=sorted(FACTORIES),
        default=DEFAULT_BACKEND,
        help=f"physics backbone (default {DEFAULT_BACKEND}: the reference physics; bullet: the "
        f"pybullet chain)",
    )
    ap.add_argument(
        "--quick",
        action="store_true",
        help="coarse grid (5 forces, 0 and 200 g, 2 resolutions, 2 disk counts) for a smoke run",
    )
    ap.add_argument(
        "--forces",
        type=int_at_least(2),
        default=None,
        help="number of tensions from 0 to --max-force on cable 1 (default 17: 5 N steps)",
    )
    ap.add_argument(
        "--max-force",
        type=positive_float,
        default=None,
        help="largest tension on cable 1, N (default: max_tension = 80 N, the paper's)",
    )
    ap.add_argument(
        "--payloads-g",
        type=_float_list("--payloads-g"),
        default=None,
        help="tip payloads in grams, comma-separated (default 0,50,100,150,200)",
    )
    ap.add_argument(
        "--links-per-span",
        type=positive_int,
        default=None,
        help="links per disk span of the main sweeps (default: 1 on mujoco, 4 on bullet)",
    )
    ap.add_argument(
        "--resolution",
        type=_int_list("--resolution"),
        default=None,
        help="links per disk span of the model-resolution study (default 1,2,4)",
    )
    ap.add_argument(
        "--disks",
        type=_int_list("--disks"),
        default=None,
        help="disk counts of the disk-count study (default 3,5,9,17,33)",
    )
    ap.add_argument("--no-horizontal", action="store_true", help="skip the horizontal-base sweep")
    ap.add_argument(
        "--threshold-pct",
        type=positive_float,
        default=1.0,
        help="error (%% of the length) above which CCKA is said to fail (default 1)",
    )
    ap.add_argument(
        "--settle-tol",
        type=positive_float,
        default=1e-6,
        help="settling tolerance: tip motion (m) over one check window (default 1e-6)",
    )
    ap.add_argument(
        "--settle-max-steps",
        type=positive_int,
        default=5000,
        help="cap on control steps spent settling one state (default 5000)",
    )
    ap.add_argument(
        "--dpi",
        type=int_at_least(30),
        default=100,
        help="figure resolution (default 100)",
    )
    ap.add_argument(
        "--report-copy",
        type=Path,
        default=None,
        help="also write the report to this Markdown file, with figure links "
        "relative to it (used for docs/reproduce.md)",
    )
    return ap


def _check_out(ap: argparse.ArgumentParser, out: Path, what: str) -> None:
    """A usage error unless ``out`` is (or can be created as) a directory this process can write
    into, checked before the study runs: the nearest existing ancestor is probed with a
    temporary file (``os.access`` passes for root on read-only places such as ``/proc``)."""

    if out.exists() and not out.is_dir():
        ap.error(f"{what} {str(out)!r} exists and is not a directory")
    parent = out
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        ap.error(f"{what} {str(out)!r}: {str(parent)!r} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        ap.error(f"{what} {str(out)!r}: {str(parent)!r} is not writable")
    try:
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as exc:
        ap.error(f"{what} {str(out)!r}: cannot write into {str(parent)!r} ({exc.strerror})")


def config_from_args(args: argparse.Namespace) -> StudyConfig:
    """The :class:`StudyConfig` an argument namespace asks for."""
    params = RobotParams()
    fmax = args.max_force if args.max_force is not None else params.max_tension
    n = args.forces or (5 if args.quick else 17)
    kw: dict = {
        "forces": tuple(np.linspace(0.0, fmax, n).tolist()),
        "resolution_forces": tuple(np.linspace(0.0, fmax, 3 if args.quick else 5).tolist()),
    }
    if args.payloads_g is not None:
        kw["payloads"] = tuple(v / 1e3 for v in args.payloads_g)
    if args.disks is not None:
        kw["n_disks_values"] = args.disks
    if args.resolution is not None:
        kw["links_per_span_values"] = args.resolution
    kw["links_per_span"] = (
        args.links_per_span
        if args.links_per_span is not None
        else DEFAULT_LINKS_PER_SPAN[getattr(args, "backend", "bullet")]
    )
    kw.update(
        horizontal=not args.no_horizontal,
        threshold_pct=args.threshold_pct,
        settle_tol=args.settle_tol,
        settle_max_steps=args.settle_max_steps,
    )
    return quick_config(**kw) if args.quick else StudyConfig(**kw)


def main(argv: Sequence[str] | None = None, factory: BackendFactory | None = None) -> int:
    """Entry point; returns the exit code (0 on success). ``factory`` (tests) overrides
    ``--backend``."""
    ap = build_parser()
    args = ap.parse_args(argv)
    if factory is None:
        factory = FACTORIES[args.backend]
    _check_out(ap, args.out, "--out")
    if args.report_copy is not None:
        if args.report_copy.suffix.lower() != ".md":
            ap.error(f"--report-copy must name a .md file, got {str(args.report_copy)!r}")
        _check_out(ap, args.report_copy.parent, "--report-copy folder")
    if args.max_force is not None and args.max_force > RobotParams().max_tension:
        ap.error(
            f"--max-force must be <= max_tension = {RobotParams().max_tension} N, "
            f"got {args.max_force}"
        )
    try:
        config = config_from_args(args)
    except ValueError as exc:
        ap.error(str(exc))
    command = "cdcr-gym reproduce " + " ".join(sys.argv[1:] if argv is None else list(argv))
    t0 = time.perf_counter()
    try:
        res = run_study(config, factory=factory)
    except SettleError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except ValueError as exc:  # a configuration the backend refuses (found before any sweep)
        print(f"error: {exc}", file=sys.stderr)
        return 2
    paths = write_outputs(res, args.out, dpi=args.dpi, command=command.strip())
    if args.report_copy is not None:
        findings = report.findings(res)
        args.report_copy.parent.mkdir(parents=True, exist_ok=True)
        args.report_copy.write_text(
            report.render(
                res,
                summary_rows(res),
                findings,
                figures=paths,
                fig_dir=args.out,
                report_dir=args.report_copy.parent,
                command=command.strip(),
            )
        )
    print(
        f"done in {time.perf_counter() - t0:.1f} s: {len(paths)} files in {args.out}/ "
        f"(report: {paths['report']})"
    )
    return 0
