"""The study's outputs: one CSV per sweep, ``summary.csv``, the figures (:mod:`.plots`), ``report.md``
(:mod:`.report`) and ``run.json``."""

from __future__ import annotations

import csv
import json
import platform
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np

from training.studies.reproduce import plots, report
from training.studies.reproduce.study import PAPER_RESULTS, StudyResults, Sweep, backend_label

# ---------------------------------------------------------------------------------------------
# Outputs
# ---------------------------------------------------------------------------------------------


def _write_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence]) -> None:
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for row in rows:
            w.writerow([_fmt(v) for v in row])


def _fmt(v) -> str:
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.9g}"
    return str(v)


SWEEP_HEADER = (
    "sweep",
    "gravity",
    "tip_payload_kg",
    "n_disks",
    "links_per_span",
    "force_N",
    "T1_N",
    "T2_N",
    "T3_N",
    "tip_sim_x_m",
    "tip_sim_y_m",
    "tip_sim_z_m",
    "l1_m",
    "l2_m",
    "l3_m",
    "tip_ccka_x_m",
    "tip_ccka_y_m",
    "tip_ccka_z_m",
    "err_x_m",
    "err_y_m",
    "err_z_m",
    "err_norm_m",
    "err_pct_of_length",
    "settle_steps",
    "settle_motion_m",
    "settle_drift_m",
    "settle_route",
)


def sweep_rows(s: Sweep, length: float) -> list[list]:
    """CSV rows of one sweep (see :data:`SWEEP_HEADER`)."""
    err = s.error
    en = s.error_norm
    return [
        [
            s.label,
            int(s.gravity),
            s.payload,
            s.n_disks,
            s.links_per_span,
            s.forces[i],
            *s.tensions[i],
            *s.tip_sim[i],
            *s.lengths[i],
            *s.tip_ccka[i],
            *err[i],
            en[i],
            100.0 * en[i] / length,
            int(s.settle_steps[i]),
            s.settle_motion[i],
            s.settle_drift[i],
            s.settle_route[i],
        ]
        for i in range(s.forces.size)
    ]


def summary_rows(res: StudyResults) -> list[dict]:
    """The table: our sweeps (mean/max error, mm and % ℓ) and the paper's two numbers."""
    ell = res.config.params.length
    rows = []

    def add(name: str, s: Sweep) -> None:
        st = s.stats(ell)
        rows.append(
            {
                "case": name,
                "source": f"this study ({backend_label(res.backend_name)})",
                "mean_mm": 1e3 * st["mean_m"],
                "mean_pct": st["mean_pct"],
                "max_mm": 1e3 * st["max_m"],
                "max_pct": st["max_pct"],
                "force_at_max_N": st["force_at_max_N"],
            }
        )

    add("CCKA vs simulation, gravity off (as the paper's simulation)", res.gravity_off)
    add("CCKA vs simulation, gravity on (upright)", res.gravity_on)
    for s in res.payload:
        if s.payload > 0.0:
            add(f"gravity on + {1e3 * s.payload:g} g tip payload", s)
    if res.horizontal is not None:
        add("gravity on, horizontal base", res.horizontal)
    for label, mm, pct in PAPER_RESULTS:
        rows.append(
            {
                "case": label,
                "source": "paper, section 4.4",
                "mean_mm": mm,
                "mean_pct": pct,
                "max_mm": float("nan"),
                "max_pct": float("nan"),
                "force_at_max_N": float("nan"),
            }
        )
    return rows


def write_outputs(res: StudyResults, out: Path, *, dpi: int = 100, command: str = "") -> dict:
    """Write CSVs, figures, ``report.md`` and ``run.json`` into ``out``; return the paths."""
    out.mkdir(parents=True, exist_ok=True)
    p = res.config.params
    ell = p.length
    paths: dict[str, Path] = {}

    c = res.ccka
    paths["ccka_csv"] = out / "ccka_cable_sweep.csv"
    _write_csv(
        paths["ccka_csv"],
        ("dl_m", "l1_m", "l2_m", "l3_m", "theta_rad", "tip_x_m", "tip_y_m", "tip_z_m"),
        [[c.dl[i], *c.lengths[i], c.theta[i], *c.tip[i]] for i in range(c.dl.size)],
    )
    sweeps = {
        "sim_gravity_off.csv": [res.gravity_off],
        "sim_gravity_on.csv": [res.gravity_on],
        "payload.csv": res.payload,
        "resolution.csv": res.resolution_links + res.resolution_links_on + res.resolution_disks,
    }
    if res.horizontal is not None:
        sweeps["horizontal_base.csv"] = [res.horizontal]
    for name, group in sweeps.items():
        rows = [r for s in group for r in sweep_rows(s, ell)]
        paths[name] = out / name
        _write_csv(paths[name], SWEEP_HEADER, rows)

    summary = summary_rows(res)
    paths["summary_csv"] = out / "summary.csv"
    keys = ("case", "source", "mean_mm", "mean_pct", "max_mm", "max_pct", "force_at_max_N")
    _write_csv(paths["summary_csv"], keys, [[r[k] for k in keys] for r in summary])

    paths.update(plots.make_figures(res, out, dpi=dpi))
    findings = report.findings(res)
    paths["report"] = out / "report.md"
    paths["report"].write_text(
        report.render(
            res, summary, findings, figures=paths, fig_dir=out, report_dir=out, command=command
        )
    )
    run = {
        "command": command,
        "seconds": res.seconds,
        "backend": res.backend_name,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "params": asdict(p),
        "config": {k: v for k, v in asdict(res.config).items() if k != "params"},
        "findings": findings,
        "sweep_seconds": {s.label: s.seconds for s in _all_sweeps(res)},
    }
    paths["run_json"] = out / "run.json"
    paths["run_json"].write_text(json.dumps(run, indent=2, default=_json_default))
    return paths


def _all_sweeps(res: StudyResults) -> list[Sweep]:
    seen: list[Sweep] = []
    for s in [
        res.gravity_off,
        res.gravity_on,
        *res.payload,
        *res.resolution_links,
        *res.resolution_links_on,
        *res.resolution_disks,
        *([res.horizontal] if res.horizontal else []),
    ]:
        if all(s is not t for t in seen):
            seen.append(s)
    return seen


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
