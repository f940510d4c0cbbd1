"""The Markdown report of ``python -m training.reproduce``: numbers computed from the run only.

:func:`findings` condenses a :class:`training.reproduce.StudyResults` into plain numbers (and the
"where CCKA stops holding" paragraph built from them); :func:`render` writes the report around
them. Nothing here is hand-typed except the paper's two published errors
(:data:`training.reproduce.PAPER_RESULTS`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from cdcr_gym import statics

__all__ = ["crossing", "findings", "render", "FIGURE_CAPTIONS"]

#: Figure key -> (title in the report, caption).
FIGURE_CAPTIONS: dict[str, tuple[str, str]] = {
    "fig06": (
        "Fig. 6 analogue — CCKA alone",
        "Cable lengths l1 = ℓ − Δl, l2 = l3 = ℓ + Δl/2 (left) and the CCKA tip (paper eq. 5, "
        "corrected) they give (right).",
    ),
    "fig07": (
        "Fig. 7 analogue — CCKA backbone shapes",
        "Constant-curvature backbones for a few Δl, in 3-D and in the bending plane.",
    ),
    "fig05": (
        "Fig. 5 analogue — physics alone",
        "Settled tip of the pybullet backbone against the tension on cable 1, gravity off and "
        "on, with the continuous pure-moment elastica θ = T·r·ℓ/EI for reference.",
    ),
    "fig10": (
        "Fig. 10 analogue — simulation vs CCKA",
        "Simulated tip (lines) and the CCKA tip computed from the simulated (sensed) cable "
        "lengths (markers), per axis.",
    ),
    "fig11": (
        "Fig. 11 analogue — CCKA error, gravity off",
        "Per-axis and Euclidean distance between the CCKA tip and the simulated tip, gravity off "
        "as in the paper's SolidWorks simulation.",
    ),
    "fig12": (
        "Fig. 12 analogue — CCKA error, gravity on",
        "The same with gravity on (the paper's Fig. 12 compares with its experiment, where "
        "gravity acts).",
    ),
    "payload": (
        "Beyond the paper — tip payload",
        "CCKA error against the force for each tip payload (gravity on), and its mean and max "
        "over the sweep against the payload.",
    ),
    "shapes": (
        "Beyond the paper — where the shape stops being an arc",
        "Simulated backbones (solid) and the CCKA arcs computed from their sensed cable lengths "
        "(dashed), in the bending plane.",
    ),
    "resolution": (
        "Beyond the paper — model resolution",
        "CCKA error and bending angle against the number of links, for more spacer disks (one "
        "link per span) and for more links per span at the paper's 9 disks (gravity off).",
    ),
}


def crossing(x: np.ndarray, y: np.ndarray, level: float) -> float | None:
    """First ``x`` where ``y`` reaches ``level`` (linear interpolation), or ``None`` if never."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if y[0] >= level:
        return float(x[0])
    for i in range(1, x.size):
        if y[i] >= level:
            return float(x[i - 1] + (level - y[i - 1]) * (x[i] - x[i - 1]) / (y[i] - y[i - 1]))
    return None


def _mm(v_m: float) -> str:
    return f"{1e3 * v_m:.2f} mm"


def _pct(v_m: float, ell: float) -> str:
    return f"{100.0 * v_m / ell:.2f} %"


def findings(res) -> dict:
    """Numbers condensed from the run, and the "where CCKA stops holding" paragraph.

    Returns a JSON-serialisable dict (SI units: m, N, kg, rad).
    """
    from training.reproduce import robot_mass

    cfg = res.config
    p = cfg.params
    ell = p.length
    thr = cfg.threshold_pct / 100.0 * ell
    off, on = res.gravity_off, res.gravity_on
    f_max = float(off.forces[-1])
    out: dict = {
        "length_m": ell,
        "threshold_pct": cfg.threshold_pct,
        "threshold_m": thr,
        "robot_mass_kg": robot_mass(p),
        "max_force_N": f_max,
        "gravity_off": off.stats(ell),
        "gravity_on": on.stats(ell),
        "gravity_on_crossing_N": crossing(on.forces, on.error_norm, thr),
        "gravity_off_crossing_N": crossing(off.forces, off.error_norm, thr),
    }
    # straightness at zero force
    zero = int(np.argmin(off.forces))
    straight = np.array([0.0, 0.0, ell])
    out["zero_force_tip_offset_off_m"] = float(np.linalg.norm(off.tip_sim[zero] - straight))
    out["zero_force_tip_offset_on_m"] = float(np.linalg.norm(on.tip_sim[zero] - straight))
    # bending vs the continuous elastica at the largest force
    theta_el, _ = statics.arc_from_tensions(np.array([f_max, 0.0, 0.0]), p)
    out["theta_elastica_rad"] = float(theta_el)
    out["theta_sim_off_rad"] = float(off.theta_sim[-1])
    out["theta_ccka_off_rad"] = float(off.theta_ccka[-1])
    # payload
    pl = [(s.payload, s.stats(ell)) for s in res.payload]
    masses = np.array([m for m, _ in pl])
    means = np.array([st["mean_m"] for _, st in pl])
    maxes = np.array([st["max_m"] for _, st in pl])
    out["payload"] = [{"payload_kg": m, **st} for m, st in pl]
    out["payload_max_crossing_kg"] = crossing(masses, maxes, thr) if len(pl) > 1 else None
    out["payload_mean_crossing_kg"] = crossing(masses, means, thr) if len(pl) > 1 else None
    heaviest = res.payload[-1]
    out["heaviest_payload_kg"] = heaviest.payload
    out["heaviest_payload_crossing_N"] = crossing(heaviest.forces, heaviest.error_norm, thr)
    out["payload_monotonic"] = bool(np.all(np.diff(means) > 0.0)) if len(pl) > 1 else None
    # resolution
    def res_rows(sweeps):
        return [
            {"n_disks": s.n_disks, "links_per_span": s.links_per_span,
             "n_links": s.n_disks * s.links_per_span, **s.stats(ell),
             "theta_sim_rad": float(s.theta_sim[-1]), "force_N": float(s.forces[-1])}
            for s in sweeps
        ]
    out["resolution_disks"] = res_rows(res.resolution_disks)
    out["resolution_links"] = res_rows(res.resolution_links)
    # horizontal base
    if res.horizontal is not None:
        h = res.horizontal
        hz = int(np.argmin(h.forces))
        out["horizontal"] = {
            **h.stats(ell),
            "zero_force_error_m": float(h.error_norm[hz]),
            "zero_force_sag_m": float(np.linalg.norm(h.tip_sim[hz] - straight)),
        }
    # settling
    sweeps = [off, on, *res.payload, *res.resolution_disks, *res.resolution_links]
    if res.horizontal is not None:
        sweeps.append(res.horizontal)
    out["settle"] = {
        "states": int(sum(s.forces.size for s in sweeps)),
        "max_motion_m": float(max(s.settle_motion.max() for s in sweeps)),
        "max_drift_m": float(max(s.settle_drift.max() for s in sweeps)),
        "max_steps": int(max(s.settle_steps.max() for s in sweeps)),
        "tol_m": cfg.settle_tol,
    }
    out["paragraph"] = _paragraph(out, res)
    return out


def _paragraph(f: dict, res) -> str:
    ell = f["length_m"]
    thr_txt = f"{f['threshold_pct']:g} % of ℓ ({_mm(f['threshold_m'])})"
    off, on = f["gravity_off"], f["gravity_on"]
    fmax = f["max_force_N"]
    s = []
    s.append(
        f"With gravity off, as in the paper's simulation, CCKA fed with the sensed cable lengths "
        f"stays within {_mm(off['max_m'])} ({off['max_pct']:.2f} % of ℓ) of the simulated tip over "
        f"0–{fmax:g} N (mean {_mm(off['mean_m'])}, {off['mean_pct']:.2f} %): the pure cable moment "
        f"bends the backbone into an arc, and CCKA holds."
    )
    cross_on = f["gravity_on_crossing_N"]
    mass_g = 1e3 * f["robot_mass_kg"]
    if cross_on is None:
        s.append(
            f"With gravity on (the robot's own {mass_g:.0f} g, upright), the error grows with the "
            f"bend but stays below {thr_txt} up to {fmax:g} N (max {_mm(on['max_m'])}, "
            f"{on['max_pct']:.2f} %)."
        )
    else:
        s.append(
            f"With gravity on (the robot's own {mass_g:.0f} g, upright), the error grows with the "
            f"bend and passes {thr_txt} at ≈ {cross_on:.0f} N on cable 1 (max "
            f"{_mm(on['max_m'])}, {on['max_pct']:.2f} %, at {on['force_at_max_N']:g} N)."
        )
    pl = f["payload"]
    if len(pl) > 1:
        last = pl[-1]
        pm = f["payload_max_crossing_kg"]
        if pm is None:
            s.append(
                f"A tip payload up to {1e3 * last['payload_kg']:g} g raises the error (max "
                f"{_mm(last['max_m'])}, {last['max_pct']:.2f} % of ℓ) without passing {thr_txt}."
            )
        else:
            hc = f["heaviest_payload_crossing_N"]
            at = "" if hc is None else f"; with {1e3 * last['payload_kg']:g} g it does so from ≈ {hc:.0f} N on"
            s.append(
                f"A tip payload bends the robot unevenly (the weight's moment grows towards the "
                f"base, so the curvature is no longer constant): from ≈ {1e3 * pm:.0f} g on "
                f"({100.0 * pm / f['robot_mass_kg']:.0f} % of the robot's mass) the largest error "
                f"over the sweep exceeds {thr_txt}{at}, and at {1e3 * last['payload_kg']:g} g it "
                f"reaches {_mm(last['max_m'])} ({last['max_pct']:.2f} % of ℓ; mean "
                f"{_mm(last['mean_m'])})."
            )
    if "horizontal" in f:
        h = f["horizontal"]
        s.append(
            f"With the base horizontal, gravity acts across the backbone even at zero tension: the "
            f"cantilever sags {_mm(h['zero_force_sag_m'])} while CCKA, seeing almost equal cable "
            f"lengths, predicts the straight robot (error {_mm(h['zero_force_error_m'])}, "
            f"{100 * h['zero_force_error_m'] / ell:.2f} % of ℓ; max {h['max_pct']:.2f} % over the "
            f"sweep)."
        )
    rd = f["resolution_disks"]
    if len(rd) > 1:
        lo, hi = rd[0], rd[-1]
        s.append(
            f"Model resolution matters little for the CCKA error with gravity off "
            f"({lo['n_disks']} disks: max {_mm(lo['max_m'])}; {hi['n_disks']} disks: max "
            f"{_mm(hi['max_m'])}), but it sets how far the robot bends: at {lo['force_N']:g} N the "
            f"bending angle is {math.degrees(lo['theta_sim_rad']):.1f}° with {lo['n_disks']} disks "
            f"and {math.degrees(hi['theta_sim_rad']):.1f}° with {hi['n_disks']}, against "
            f"{math.degrees(f['theta_elastica_rad']):.1f}° for the continuous elastica."
        )
    s.append(_closing(f, thr_txt))
    return " ".join(s)


def _closing(f: dict, thr_txt: str) -> str:
    parts = [f"In short: under cable loads alone CCKA holds (error below {thr_txt})"]
    stops = []
    if f["gravity_on_crossing_N"] is not None:
        stops.append(f"self-weight at bends beyond ≈ {f['gravity_on_crossing_N']:.0f} N")
    if f.get("payload_max_crossing_kg") is not None:
        stops.append(f"a tip payload of ≈ {1e3 * f['payload_max_crossing_kg']:.0f} g or more")
    if "horizontal" in f and f["horizontal"]["max_pct"] > f["threshold_pct"]:
        stops.append("gravity across the backbone (horizontal base)")
    if stops:
        parts.append("; it stops holding with " + ", ".join(stops))
    else:
        parts.append("; none of the loads studied here pushed it past that bound")
    return "".join(parts) + "."


def _rel(path: Path, report_dir: Path) -> str:
    return Path(os.path.relpath(Path(path).resolve(), Path(report_dir).resolve())).as_posix()


def _num(v: float, fmt: str) -> str:
    return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)


def table_markdown(summary: list[dict]) -> str:
    """The error table as Markdown."""
    lines = [
        "| case | mean error (mm) | mean (% of ℓ) | max error (mm) | max (% of ℓ) | force at max (N) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in summary:
        lines.append(
            f"| {r['case']} | {_num(r['mean_mm'], '.2f')} | {_num(r['mean_pct'], '.2f')} | "
            f"{_num(r['max_mm'], '.2f')} | {_num(r['max_pct'], '.2f')} | "
            f"{_num(r['force_at_max_N'], '.0f')} |"
        )
    return "\n".join(lines)


def render(res, summary: list[dict], f: dict, *, figures: dict, fig_dir: Path,
           report_dir: Path, command: str) -> str:
    """The Markdown report; figure links are relative to ``report_dir``."""
    cfg = res.config
    p = cfg.params
    ell = p.length
    forces = res.gravity_off.forces
    pl_g = ", ".join(f"{1e3 * s.payload:g}" for s in res.payload)
    st = f["settle"]
    lines = [
        "# Reproducing the paper's CCKA study with the pybullet backbone",
        "",
        f"Produced by `{command}` in {res.seconds:.0f} s.",
        "",
        "## Method",
        "",
        f"The paper pulls cable 1 with 0–80 N in a nonlinear SolidWorks simulation, feeds the "
        f"simulated cable lengths to the constant-curvature forward kinematics (CCKA, its eq. 5) "
        f"and reports the distance between the two tips. We do the same with the pybullet "
        f"multibody backbone in place of SolidWorks: {p.n_disks} spacer disks, "
        f"{cfg.links_per_span} rigid link(s) per disk span joined by 2-DOF bending joints of "
        f"stiffness EI/Δs (E = {p.youngs_modulus / 1e9:g} GPa, d = {1e3 * p.backbone_diameter:g} mm, "
        f"ℓ = {1e3 * ell:g} mm, r = {1e3 * p.cable_radius:g} mm; the paper's \"35 MPa\" is a unit "
        f"slip, see `cdcr_gym/params.py`), frictionless cables straight between pinholes. For "
        f"{forces.size} tensions from {forces[0]:g} to {forces[-1]:g} N on cable 1 we put the "
        f"backbone at its static equilibrium and verify it (the tip moves less than "
        f"{st['tol_m']:g} m over {cfg.settle_window} more control steps at the same tensions), read "
        f"the tip and the sensed cable lengths (sums of pinhole-to-pinhole segments), and compute "
        f"the CCKA tip from those lengths. We do it with gravity off (as the paper's simulation) "
        f"and on (upright base, robot mass {1e3 * f['robot_mass_kg']:.0f} g), then go further: a "
        f"tip payload of {pl_g} g, the number of links (model resolution), and a horizontal base.",
        "",
        "## Results",
        "",
        table_markdown(summary),
        "",
        f"Mean and max are over the {forces.size} tensions of each sweep (0–{forces[-1]:g} N on "
        f"cable 1); ℓ = {1e3 * ell:g} mm. The paper reports mean errors only.",
        "",
        "### Where CCKA stops holding",
        "",
        f["paragraph"],
        "",
        "## Figures",
        "",
    ]
    for key, (title, caption) in FIGURE_CAPTIONS.items():
        if key not in figures:
            continue
        lines += [f"**{title}.** {caption}", "", f"![{title}]({_rel(figures[key], report_dir)})", ""]
    lines += [
        "## Data and checks",
        "",
        f"- Every one of the {st['states']} simulated states was verified settled: largest tip "
        f"motion over the final check window {st['max_motion_m']:.2g} m, largest move after the "
        f"backend's reset-to-equilibrium {st['max_drift_m']:.2g} m, at most {st['max_steps']} "
        f"control steps per state.",
        f"- Zero force: the tip sits {f['zero_force_tip_offset_off_m']:.2g} m (gravity off) and "
        f"{f['zero_force_tip_offset_on_m']:.2g} m (gravity on, upright) from the straight "
        f"robot's (0, 0, ℓ).",
        f"- At {f['max_force_N']:g} N, gravity off: bending angle {math.degrees(f['theta_sim_off_rad']):.1f}° "
        f"(simulated tip), {math.degrees(f['theta_ccka_off_rad']):.1f}° (CCKA from the sensed "
        f"lengths), {math.degrees(f['theta_elastica_rad']):.1f}° (continuous elastica "
        f"T·r·ℓ/EI; the discrete robot bends a little more because the cable is straight between "
        f"disks).",
        "- CSV files (SI units, unit in each column name): "
        + ", ".join(
            f"[{n}]({_rel(Path(fig_dir) / n, report_dir)})"
            for n in ("summary.csv", "ccka_cable_sweep.csv", "sim_gravity_off.csv",
                      "sim_gravity_on.csv", "payload.csv", "resolution.csv",
                      *(("horizontal_base.csv",) if res.horizontal is not None else ()))
        )
        + "; configuration and timings in "
        + f"[run.json]({_rel(Path(fig_dir) / 'run.json', report_dir)}).",
        "",
    ]
    return "\n".join(lines)
