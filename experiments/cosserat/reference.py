"""The committed reference (``docs/figures/physics/cosserat_reference.json``): its cases, how it
is written and read, and the comparison of the package's models with it (``--study``).

Regenerate (static solver only, ~1 min; add ``--pyelastica`` to rerun the cross-check cases,
~3–7 min per case on a shared 2-core machine)::

    python -m experiments.cosserat --write docs/figures/physics/cosserat_reference.json

Compare the package's models with it::

    python -m experiments.cosserat --study

The JSON schema is in :mod:`experiments.cosserat` (the package docstring).
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import cdcr_gym
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.model.params import PRESETS, RobotParams
from experiments.cosserat.pyelastica_solver import solve_pyelastica
from experiments.cosserat.rod import solve_static
from training.run.argtypes import positive_int

__all__ = [
    "CASES",
    "REFERENCE_PATH",
    "reference_cases",
    "write_reference",
    "refine_pyelastica",
    "load_reference",
    "model_tips",
    "study",
    "main",
]

REFERENCE_PATH = (
    Path(__file__).resolve().parents[2] / "docs/figures/physics/cosserat_reference.json"
)

# ----------------------------------------------------------------------------- the reference
#: (name, preset, tensions) of the reference cases; each is solved with gravity off and on.
CASES: tuple[tuple[str, str, tuple[float, ...]], ...] = (
    ("paper_zero", "paper", (0.0, 0.0, 0.0)),
    ("paper_c1_10N", "paper", (10.0, 0.0, 0.0)),
    ("paper_c1_20N", "paper", (20.0, 0.0, 0.0)),
    ("paper_c1_40N", "paper", (40.0, 0.0, 0.0)),
    ("paper_c1_60N", "paper", (60.0, 0.0, 0.0)),
    ("paper_c1_80N", "paper", (80.0, 0.0, 0.0)),
    ("paper_c1_60N_c2_30N", "paper", (60.0, 30.0, 0.0)),
    ("tdcr2_zero", "tdcr2", (0.0,) * 6),
    ("tdcr2_s1c1_2N", "tdcr2", (2.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("tdcr2_s2c1_1N", "tdcr2", (0.0, 0.0, 0.0, 1.0, 0.0, 0.0)),
    ("tdcr2_s2c1_2N", "tdcr2", (0.0, 0.0, 0.0, 2.0, 0.0, 0.0)),
    ("tdcr2_s2c1_3N", "tdcr2", (0.0, 0.0, 0.0, 3.0, 0.0, 0.0)),
    ("tdcr2_s1c3_2N_s2c1_3N", "tdcr2", (0.0, 0.0, 2.0, 3.0, 0.0, 0.0)),
)

#: Cases (name, gravity) rerun with PyElastica as the cross-check, with the meshes tried.
PYELASTICA_CASES: tuple[tuple[str, bool], ...] = (
    ("paper_c1_80N", False),
    ("paper_c1_80N", True),
    ("tdcr2_s1c3_2N_s2c1_3N", True),
)
#: Elements per disk span tried per preset (the last is recorded; its change from the one
#: before is the convergence delta, < 0.3 mm required).
PYELASTICA_MESHES = {"paper": (4, 8, 16), "tdcr2": (2, 4, 8)}

GENERATOR = "python -m experiments.cosserat --write docs/figures/physics/cosserat_reference.json"


def reference_cases() -> list[dict]:
    """The cases as dicts (name, robot, gravity, tensions), gravity off then on for each."""
    return [
        {"name": name, "robot": robot, "gravity": g, "tensions": list(t)}
        for name, robot, t in CASES
        for g in (False, True)
    ]


def _static_case(case: dict, rtol: float = 1e-9) -> dict:
    params = RobotParams.preset(case["robot"])
    sol = solve_static(params, case["tensions"], case["gravity"], rtol=rtol)
    fine = solve_static(params, case["tensions"], case["gravity"], rtol=rtol * 1e-2, guess=sol)
    out = dict(case)
    out.update(
        tip=sol.tip.tolist(),
        disk_centres=sol.disk_centres.tolist(),
        solver="cosserat_shooting",
        mesh=None,
        rtol=rtol,
        convergence_delta=float(np.linalg.norm(fine.tip - sol.tip)),
        pyelastica=None,
        command=GENERATOR,
    )
    return out


def _pyelastica_case(case: dict) -> dict:
    params = RobotParams.preset(case["robot"])
    meshes = PYELASTICA_MESHES[case["robot"]]
    runs = {
        m: solve_pyelastica(params, case["tensions"], case["gravity"], elements_per_span=m)
        for m in meshes
    }
    fine, coarse = runs[meshes[-1]], runs[meshes[-2]]
    return {
        "tip": fine["tip"].tolist(),
        "elements_per_span": meshes[-1],
        "convergence_delta": float(np.linalg.norm(fine["tip"] - coarse["tip"])),
        "difference_to_reference": float(np.linalg.norm(fine["tip"] - np.asarray(case["tip"]))),
        "final_velocity": fine["final_velocity"],
        "seconds": fine["seconds"],
        "meshes": {str(m): r["tip"].tolist() for m, r in runs.items()},
    }


def write_reference(
    path: Path,
    pyelastica: bool = False,
    previous: dict | None = None,
    robots: Sequence[str] | None = None,
) -> dict:
    """Solve every case and write the JSON (module docstring), rewriting the file after each
    case; with ``pyelastica`` also rerun :data:`PYELASTICA_CASES` (else keep their PyElastica
    entries from ``previous``). ``robots``: only the cases of these presets (the others are
    kept from ``previous``)."""

    old = {}
    if previous is not None:
        old = {(c["name"], c["gravity"]): c for c in previous["cases"]}
    doc = {
        "generator": GENERATOR + (" --pyelastica" if pyelastica else ""),
        "package_version": cdcr_gym.__version__,
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "frame": "R0: base disk centre, backbone along +Z0 (upright, gravity -Z0), cable 1 at "
        "+X0; metres, newtons",
        "model": "Cosserat rod (E, G = E/(2(1+0.3)), shear factor 27/28, extensible) clamped at "
        "the base disk; rigid disks at their stations; each cable straight between consecutive "
        "pinholes, point forces T(u_out - u_in) at every pinhole (anchor: -T u_in), following "
        "the deformed shape; gravity: rod weight per length + disk weights at the disk centres",
        "cases": [],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    for case in reference_cases():
        key = (case["name"], case["gravity"])
        if robots is not None and case["robot"] not in robots:
            if key in old:
                doc["cases"].append(old[key])
            continue
        t0 = time.perf_counter()
        out = _static_case(case)
        if pyelastica and key in PYELASTICA_CASES:
            out["pyelastica"] = _pyelastica_case(out)
            out["command"] = GENERATOR + " --pyelastica"
        elif key in old and old[key].get("pyelastica") is not None:
            out["pyelastica"] = old[key]["pyelastica"]
            out["pyelastica"]["difference_to_reference"] = float(
                np.linalg.norm(np.asarray(out["pyelastica"]["tip"]) - np.asarray(out["tip"]))
            )
            out["command"] = GENERATOR + " --pyelastica"
        print(
            f"{case['name']:<24} gravity={case['gravity']!s:<5} tip "
            f"{np.round(np.asarray(out['tip']) * 1e3, 3)} mm  ({time.perf_counter() - t0:.1f} s)",
            file=sys.stderr,
            flush=True,
        )
        doc["cases"].append(out)
        path.write_text(json.dumps(doc, indent=1) + "\n")
    return doc


def refine_pyelastica(path: Path, name: str, gravity: bool, elements_per_span: int) -> dict:
    """Add a finer PyElastica mesh to one case of the JSON at ``path`` (its ``pyelastica``
    entry then records that mesh, its change from the finest before, and the difference to
    the reference)."""
    doc = load_reference(path)
    case = next(c for c in doc["cases"] if c["name"] == name and c["gravity"] == gravity)
    pe = case["pyelastica"]
    run = solve_pyelastica(
        RobotParams.preset(case["robot"]),
        case["tensions"],
        gravity,
        elements_per_span=elements_per_span,
    )
    finest = np.asarray(pe["meshes"][str(max(int(m) for m in pe["meshes"]))])
    pe["meshes"][str(elements_per_span)] = run["tip"].tolist()
    pe.update(
        tip=run["tip"].tolist(),
        elements_per_span=elements_per_span,
        convergence_delta=float(np.linalg.norm(run["tip"] - finest)),
        difference_to_reference=float(np.linalg.norm(run["tip"] - np.asarray(case["tip"]))),
        final_velocity=run["final_velocity"],
        seconds=run["seconds"],
    )
    case["command"] = (
        f"{GENERATOR} --pyelastica && python -m experiments.cosserat --refine "
        f"{name}:{int(gravity)}:{elements_per_span}"
    )
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return pe


def load_reference(path: Path = REFERENCE_PATH) -> dict:
    """The committed reference (module docstring: schema)."""
    return json.loads(Path(path).read_text())


STUDY_MESHES = {"paper": (1, 2, 3, 4), "tdcr2": (1, 2, 3)}
STUDY_COMMAND = "python -m experiments.cosserat --study"


def model_tips(reference: dict) -> dict:
    """Tips (m) of the package's models on every reference case.

    Returns ``{(robot, model label): [(case, tip (3,)), …]}`` for ``BulletBackend`` at each of
    :data:`STUDY_MESHES` (its static equilibrium, ``BulletBackend.equilibrium``: the state the
    dynamics settle to, gravity as in the case) and the analytic PCC model
    (``AnalyticBackend.equilibrium``, which has no gravity).
    """

    out: dict = {}
    for robot, meshes in STUDY_MESHES.items():
        cases = [c for c in reference["cases"] if c["robot"] == robot]
        params = RobotParams.preset(robot)
        pcc = AnalyticBackend(params)
        for c in cases:
            tip = pcc.equilibrium(np.asarray([c["tensions"]]))[0][0]
            out.setdefault((robot, "PCC (analytic, no gravity)"), []).append((c, tip))
        for m in meshes:
            for g in (False, True):
                backend = BulletBackend(params, gravity=g, links_per_span=m)
                try:
                    for c in cases:
                        if c["gravity"] != g:
                            continue
                        tip = backend.equilibrium(np.asarray([c["tensions"]]))[0][0]
                        out.setdefault((robot, f"bullet links_per_span={m}"), []).append((c, tip))
                finally:
                    backend.close()
    return out


def study(reference: dict | None = None) -> str:
    """Markdown table: max tip error (mm, % of ℓ) of each model against the reference, over the
    gravity-off cases, the gravity-on cases and all."""
    reference = load_reference() if reference is None else reference
    tips = model_tips(reference)
    lines = [
        f"Max tip error against the Cosserat reference ({STUDY_COMMAND}):",
        "",
        "| robot | model | gravity off: mm (% of ℓ) | gravity on: mm (% of ℓ) | worst case |",
        "|---|---|---|---|---|",
    ]
    for (robot, label), rows in tips.items():
        ell = RobotParams.preset(robot).length
        cols = []
        worst = (0.0, "")
        for g in (False, True):
            errs = [
                (float(np.linalg.norm(tip - np.asarray(c["tip"]))), c["name"])
                for c, tip in rows
                if c["gravity"] == g
            ]
            e = max(errs)
            worst = max(worst, (e[0], f"{e[1]} (gravity {'on' if g else 'off'})"))
            cols.append(f"{e[0] * 1e3:.2f} ({100 * e[0] / ell:.2f} %)")
        lines.append(f"| {robot} | {label} | {cols[0]} | {cols[1]} | {worst[1]} |")
    return "\n".join(lines)


def _parse_refine(parser: argparse.ArgumentParser, text: str, path: Path) -> tuple[str, bool, int]:
    """``NAME:GRAVITY:M`` of --refine, checked against the cases of ``path`` (usage error)."""
    parts = text.split(":")
    if len(parts) != 3 or parts[1] not in ("0", "1"):
        parser.error(
            f"--refine {text!r}: expected NAME:GRAVITY:M, GRAVITY 0 or 1, M an integer >= 1"
        )
    name, gravity, m = parts
    try:
        elements = positive_int(m)
    except argparse.ArgumentTypeError as exc:
        parser.error(f"--refine {text!r}: M {exc}")
    if not Path(path).is_file():
        parser.error(
            f"--refine: the reference file {str(path)!r} does not exist (--write it first)"
        )
    cases = {(c["name"], c["gravity"]) for c in load_reference(path)["cases"]}
    if (name, gravity == "1") not in cases:
        names = sorted({n for n, _ in cases})
        parser.error(
            f"--refine {text!r}: no case {name!r} with gravity {gravity} in {path} (cases: {', '.join(names)})"
        )
    return name, gravity == "1", elements


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.cosserat")
    parser.add_argument("--write", type=Path, help="solve every case and write the JSON here")
    parser.add_argument(
        "--pyelastica", action="store_true", help="also rerun the PyElastica cross-check cases"
    )
    parser.add_argument("--robot", action="append", help="--write: only this preset (repeat)")
    parser.add_argument(
        "--refine",
        metavar="NAME:GRAVITY:M",
        help="add a PyElastica run with M elements per span to one case of --write's file",
    )
    parser.add_argument("--study", action="store_true", help="compare the package's models")
    parser.add_argument("--out", type=Path, default=None, help="study: write the table here")
    args = parser.parse_args(argv)
    if not (args.write or args.refine or args.study):
        parser.print_usage()
        print(
            "nothing to do: give --write FILE (solve the reference cases), --refine "
            "NAME:GRAVITY:M (a finer PyElastica mesh for one case) or --study (compare the "
            "package's models)"
        )
        return 0
    refine = None
    if args.refine:
        refine = _parse_refine(parser, args.refine, args.write or REFERENCE_PATH)
    if args.robot:
        unknown = [r for r in args.robot if r not in PRESETS]
        if unknown:
            parser.error(
                f"--robot {unknown[0]!r}: not a robot preset ({', '.join(sorted(PRESETS))})"
            )
    if args.write and not args.refine:
        previous = load_reference(args.write) if args.write.exists() else None
        write_reference(args.write, args.pyelastica, previous, args.robot)
    if refine is not None:
        refine_pyelastica(args.write or REFERENCE_PATH, *refine)
    if args.study:
        table = study()
        print(table)
        if args.out:
            args.out.write_text(table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
