"""Figures of ``python -m training.studies.reproduce`` (matplotlib, Agg, PNG; mm, N and degrees).

Every figure is built on a bare :class:`matplotlib.figure.Figure` (no pyplot state), has a title,
axis labels with units and a legend, and is written at ``dpi`` (100 by default, a few tens of kB).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from cdcr_gym import kinematics as K
from cdcr_gym.model import statics
from training.studies.reproduce.study import PAPER_RESULTS, backend_label, cable1_tensions

__all__ = ["make_figures"]

MM = 1e3
AXIS_COLOURS = {"X": "tab:red", "Y": "tab:green", "Z": "tab:blue"}


def _paper_sim_mean_mm() -> float:
    """The paper's mean CCKA-vs-SolidWorks error (mm), from :data:`training.studies.reproduce.PAPER_RESULTS`."""
    return PAPER_RESULTS[0][1]


def _figure(w: float, h: float, dpi: int):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _min_span(ax, span: float) -> None:
    """Widen the y-range to at least ``span`` (data units) so that round-off is not magnified."""
    lo, hi = ax.get_ylim()
    if hi - lo < span:
        mid = 0.5 * (lo + hi)
        ax.set_ylim(mid - span / 2, mid + span / 2)


def _save(fig, path: Path, dpi: int) -> Path:
    fig.savefig(path, dpi=dpi)
    _shrink_png(path)
    return path


def _shrink_png(path: Path) -> None:
    """Re-encode as an optimised palette PNG (≈ ⅓ of the size, visually the same) if Pillow
    is available; matplotlib depends on Pillow, so it normally is."""
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - matplotlib requires Pillow
        return
    with Image.open(path) as im:
        small = im.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    small.save(path, optimize=True)


def make_figures(res, out: Path, *, dpi: int = 100) -> dict[str, Path]:
    """Draw every figure of the study into ``out``; return {key: path}."""
    out = Path(out)
    paths = {
        "fig06": fig06_ccka_sweep(res, out / "fig06_ccka_cable_sweep.png", dpi),
        "fig07": fig07_ccka_shapes(res, out / "fig07_ccka_shapes.png", dpi),
        "fig05": fig05_sim_tip(res, out / "fig05_sim_tip_vs_force.png", dpi),
        "fig10": fig10_sim_vs_ccka(res, out / "fig10_sim_vs_ccka.png", dpi),
    }
    ymax = 1.1 * MM * max(float(s.error_norm.max()) for s in (res.gravity_off, res.gravity_on))
    ymax = max(ymax, 1.15 * MM * res.config.threshold_pct / 100.0 * res.config.params.length)
    paths["fig11"] = fig_error(
        res,
        res.gravity_off,
        out / "fig11_error_gravity_off.png",
        dpi,
        "Fig. 11 analogue — CCKA vs simulation, gravity off",
        ymax,
    )
    paths["fig12"] = fig_error(
        res,
        res.gravity_on,
        out / "fig12_error_gravity_on.png",
        dpi,
        "Fig. 12 analogue — CCKA vs simulation, gravity on (upright)",
        ymax,
    )
    if len(res.payload) > 1:
        paths["payload"] = fig_payload(res, out / "fig_payload_error.png", dpi)
    paths["shapes"] = fig_shapes(res, out / "fig_shapes_vs_arc.png", dpi)
    if res.resolution_disks or res.resolution_links:
        paths["resolution"] = fig_resolution(res, out / "fig_resolution.png", dpi)
    return paths


# ---------------------------------------------------------------------------------------------
def fig06_ccka_sweep(res, path: Path, dpi: int) -> Path:
    c = res.ccka
    ell = res.config.params.length
    fig = _figure(11, 4, dpi)
    a, b = fig.subplots(1, 2)
    dl = c.dl * MM
    a.plot(dl, c.lengths[:, 0] * MM, color="tab:red", label="l1 = ℓ − Δl (cable 1)")
    a.plot(dl, c.lengths[:, 1] * MM, color="tab:green", label="l2 = ℓ + Δl/2 (cable 2)")
    a.plot(dl, c.lengths[:, 2] * MM, color="tab:blue", ls="--", label="l3 = ℓ + Δl/2 (cable 3)")
    a.axhline(ell * MM, color="0.5", lw=0.8, ls=":", label=f"ℓ = {ell * MM:g} mm")
    a.set(xlabel="Δl (mm)", ylabel="cable length (mm)", title="(a) input: cable lengths")
    a.legend(fontsize=8)
    for i, ax_name in enumerate("XYZ"):
        b.plot(dl, c.tip[:, i] * MM, color=AXIS_COLOURS[ax_name], label=f"tip {ax_name}")
    b.plot([], [], " ", label="(Y = 0: bending plane φ = 0)")
    top = b.secondary_xaxis(
        "top",
        functions=(
            lambda x: np.degrees(x / (res.config.params.cable_radius * MM)),
            lambda d: np.radians(d) * res.config.params.cable_radius * MM,
        ),
    )
    top.set_xlabel("bending angle θ = Δl/r (degrees)")
    b.set(xlabel="Δl (mm)", ylabel="tip position (mm)", title="(b) output: CCKA tip (eq. 5)")
    b.legend(fontsize=8)
    for ax in (a, b):
        ax.grid(alpha=0.3)
    fig.suptitle("Fig. 6 analogue — CCKA alone: l1 = ℓ − Δl, l2 = l3 = ℓ + Δl/2")
    return _save(fig, path, dpi)


def fig07_ccka_shapes(res, path: Path, dpi: int) -> Path:
    import matplotlib as mpl

    c = res.ccka
    p = res.config.params
    fig = _figure(11, 5, dpi)
    a = fig.add_subplot(1, 2, 1, projection="3d")
    b = fig.add_subplot(1, 2, 2)
    cmap = mpl.colormaps["viridis"]
    n = len(c.shape_dl)
    for k, (dl, pts) in enumerate(zip(c.shape_dl, c.shapes)):
        colour = cmap(k / max(n - 1, 1))
        theta = dl / p.cable_radius
        label = f"Δl = {dl * MM:.1f} mm (θ = {math.degrees(theta):.0f}°)"
        q = pts * MM
        a.plot(q[:, 0], q[:, 1], q[:, 2], color=colour, lw=2, label=label)
        b.plot(q[:, 0], q[:, 2], color=colour, lw=2, label=label)
        th, ph, _ = K.arc_from_lengths(
            np.array([p.length - dl, p.length + dl / 2, p.length + dl / 2]), p.cable_radius
        )
        disks = K.backbone_points(th, ph, p.length, n=p.n_disks + 1) * MM
        a.scatter(disks[:, 0], disks[:, 1], disks[:, 2], color=colour, s=8)
        b.scatter(disks[:, 0], disks[:, 2], color=colour, s=10)
    reach = p.length * MM
    a.set_xlim(0, reach)
    a.set_ylim(-reach / 2, reach / 2)
    a.set_zlim(0, reach)
    a.set_xlabel("X0 (mm)")
    a.set_ylabel("Y0 (mm)")
    a.set_zlabel("Z0 (mm)")
    a.set_title("(a) backbones in 3-D (dots: disks)")
    a.view_init(elev=20, azim=-60)
    b.set_aspect("equal")
    b.set(xlabel="X0 (mm)", ylabel="Z0 (mm)", title="(b) in the bending plane (φ = 0)")
    b.grid(alpha=0.3)
    b.legend(fontsize=8, loc="lower right")
    fig.suptitle("Fig. 7 analogue — CCKA backbone shapes for a few Δl")
    return _save(fig, path, dpi)


def _elastica_tips(res, forces: np.ndarray) -> np.ndarray:
    p = res.config.params
    theta, phi = statics.arc_from_tensions(cable1_tensions(forces, p), p)
    return K.tip_from_arc(theta, phi, p.length)


def fig05_sim_tip(res, path: Path, dpi: int) -> Path:
    off, on = res.gravity_off, res.gravity_on
    fig = _figure(12, 4, dpi)
    axes = fig.subplots(1, 3, sharex=True)
    fine = np.linspace(0.0, float(off.forces[-1]), 101)
    el = _elastica_tips(res, fine)
    for i, (ax, name) in enumerate(zip(axes, "XYZ")):
        ax.plot(
            off.forces,
            off.tip_sim[:, i] * MM,
            "o-",
            ms=3,
            color="tab:blue",
            label=f"{backend_label(res.backend_name)}, gravity off",
        )
        ax.plot(
            on.forces,
            on.tip_sim[:, i] * MM,
            "s--",
            ms=3,
            color="tab:orange",
            label=f"{backend_label(res.backend_name)}, gravity on",
        )
        ax.plot(fine, el[:, i] * MM, ":", color="k", label="elastica θ = T·r·ℓ/EI")
        ax.set(xlabel="tension on cable 1 (N)", ylabel=f"tip {name} (mm)", title=f"tip {name}")
        ax.grid(alpha=0.3)
        _min_span(ax, 20.0)
    axes[0].legend(fontsize=8)
    fig.suptitle("Fig. 5 analogue — physics alone: settled tip vs tension on cable 1")
    return _save(fig, path, dpi)


def fig10_sim_vs_ccka(res, path: Path, dpi: int) -> Path:
    off, on = res.gravity_off, res.gravity_on
    fig = _figure(12, 4, dpi)
    axes = fig.subplots(1, 3, sharex=True)
    for i, (ax, name) in enumerate(zip(axes, "XYZ")):
        ax.plot(
            off.forces,
            off.tip_sim[:, i] * MM,
            "-",
            color="tab:blue",
            label="simulation, gravity off",
        )
        ax.plot(
            off.forces,
            off.tip_ccka[:, i] * MM,
            "o",
            mfc="none",
            color="tab:blue",
            label="CCKA from sensed lengths, gravity off",
        )
        ax.plot(
            on.forces,
            on.tip_sim[:, i] * MM,
            "--",
            color="tab:orange",
            label="simulation, gravity on",
        )
        ax.plot(
            on.forces,
            on.tip_ccka[:, i] * MM,
            "x",
            color="tab:orange",
            label="CCKA from sensed lengths, gravity on",
        )
        ax.set(xlabel="tension on cable 1 (N)", ylabel=f"tip {name} (mm)", title=f"tip {name}")
        ax.grid(alpha=0.3)
        _min_span(ax, 20.0)
    axes[0].legend(fontsize=7)
    fig.suptitle("Fig. 10 analogue — simulated tip vs CCKA tip from the simulated cable lengths")
    return _save(fig, path, dpi)


def fig_error(res, s, path: Path, dpi: int, title: str, ymax: float) -> Path:
    ell = res.config.params.length
    thr = res.config.threshold_pct / 100.0 * ell * MM
    fig = _figure(8, 4.5, dpi)
    ax = fig.subplots()
    err = np.abs(s.error) * MM
    for i, name in enumerate("XYZ"):
        ax.plot(s.forces, err[:, i], "o-", ms=3, color=AXIS_COLOURS[name], label=f"|error {name}|")
    ax.plot(s.forces, s.error_norm * MM, "k-", lw=2, label="Euclidean error")
    ax.axhline(
        thr, color="0.4", ls="--", lw=1, label=f"{res.config.threshold_pct:g} % of ℓ = {thr:.2f} mm"
    )
    ax.axhline(
        _paper_sim_mean_mm(),
        color="tab:purple",
        ls=":",
        lw=1.2,
        label=f"paper: mean CCKA vs SolidWorks = {_paper_sim_mean_mm()} mm",
    )
    ax.set(
        xlabel="tension on cable 1 (N)",
        ylabel="CCKA − simulation (mm)",
        title=title,
        ylim=(0, ymax),
    )
    sec = ax.secondary_yaxis(
        "right", functions=(lambda v: 100 * v / (ell * MM), lambda q: q * ell * MM / 100)
    )
    sec.set_ylabel("error (% of ℓ)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return _save(fig, path, dpi)


def fig_payload(res, path: Path, dpi: int) -> Path:
    import matplotlib as mpl

    ell = res.config.params.length
    thr = res.config.threshold_pct / 100.0 * ell * MM
    fig = _figure(12, 4.5, dpi)
    a, b = fig.subplots(1, 2)
    cmap = mpl.colormaps["plasma"]
    n = len(res.payload)
    for k, s in enumerate(res.payload):
        a.plot(
            s.forces,
            s.error_norm * MM,
            "o-",
            ms=3,
            color=cmap(0.85 * k / max(n - 1, 1)),
            label=f"payload {s.payload * MM:g} g",
        )
    a.axhline(thr, color="0.4", ls="--", lw=1, label=f"{res.config.threshold_pct:g} % of ℓ")
    a.set(
        xlabel="tension on cable 1 (N)",
        ylabel="Euclidean CCKA error (mm)",
        title="(a) error vs tension, per tip payload (gravity on)",
    )
    a.grid(alpha=0.3)
    a.legend(fontsize=8)
    g = np.array([s.payload for s in res.payload]) * MM
    mean = np.array([s.error_norm.mean() for s in res.payload]) * MM
    mx = np.array([s.error_norm.max() for s in res.payload]) * MM
    b.plot(g, mean, "o-", color="tab:blue", label=f"mean over 0–{res.payload[0].forces[-1]:g} N")
    b.plot(g, mx, "s-", color="tab:red", label="max over the sweep")
    b.axhline(thr, color="0.4", ls="--", lw=1, label=f"{res.config.threshold_pct:g} % of ℓ")
    b.axhline(
        _paper_sim_mean_mm(),
        color="tab:purple",
        ls=":",
        lw=1.2,
        label=f"paper: mean vs SolidWorks ({_paper_sim_mean_mm()} mm)",
    )
    b.set(
        xlabel="tip payload (g)",
        ylabel="Euclidean CCKA error (mm)",
        title="(b) error vs tip payload",
    )
    sec = b.secondary_yaxis(
        "right", functions=(lambda v: 100 * v / (ell * MM), lambda q: q * ell * MM / 100)
    )
    sec.set_ylabel("error (% of ℓ)")
    b.grid(alpha=0.3)
    b.legend(fontsize=8)
    fig.suptitle("Beyond the paper — CCKA error with a tip payload")
    return _save(fig, path, dpi)


def _plane_coords(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(in-plane horizontal X0, Z0) for drawing: the study bends in the X0–Z0 plane (φ = 0)."""
    return points[:, 0], points[:, 2]


def _gravity_in_base(quat) -> np.ndarray:
    """Unit gravity direction (world −Z) in the base frame R0 of a base at quaternion xyzw."""
    x, y, z, w = quat
    rot = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return rot.T @ np.array([0.0, 0.0, -1.0])


def fig_shapes(res, path: Path, dpi: int) -> Path:
    p = res.config.params
    panels = [
        (
            "(a) upright base",
            [
                res.gravity_off,
                res.gravity_on,
                *(res.payload[-1:] if res.payload[-1].payload > 0 else []),
            ],
        )
    ]
    if res.horizontal is not None:
        g = _gravity_in_base(res.horizontal.base_orientation)
        axis = "XYZ"[int(np.argmax(np.abs(g)))]
        sign = "+" if g[int(np.argmax(np.abs(g)))] > 0 else "−"
        panels.append((f"(b) horizontal base: gravity along {sign}{axis}0", [res.horizontal]))
    fig = _figure(6 * len(panels), 6.5, dpi)
    axes = np.atleast_1d(fig.subplots(1, len(panels)))
    colours = ["tab:blue", "tab:orange", "tab:red", "tab:green", "tab:purple"]
    for ax, (title, sweeps) in zip(axes, panels):
        k = 0
        for s in sweeps:
            for force, pts in sorted(s.shapes.items()):
                if len(sweeps) > 1 and force != max(s.shapes):
                    continue
                colour = colours[k % len(colours)]
                k += 1
                i = int(np.argmin(np.abs(s.forces - force)))
                th, ph, _ = K.arc_from_lengths(s.lengths[i], p.cable_radius)
                arc = K.backbone_points(th, ph, s.lengths[i].mean(), n=60)
                x, z = _plane_coords(pts * MM)
                ax.plot(x, z, "-", color=colour, lw=2, label=f"{s.label}, {force:g} N: simulation")
                xa, za = _plane_coords(arc * MM)
                ax.plot(
                    xa,
                    za,
                    "--",
                    color=colour,
                    lw=1.2,
                    label=f"CCKA arc (error {1e3 * s.error_norm[i]:.1f} mm)",
                )
        ax.set_aspect("equal")
        ax.set(xlabel="X0 (mm)", ylabel="Z0 (mm)", title=title)
        ax.grid(alpha=0.3)
        if any(sw.gravity for sw in sweeps):
            g = _gravity_in_base(sweeps[-1].base_orientation)
            start = np.array([0.12, 0.75] if abs(g[2]) >= abs(g[0]) else [0.85, 0.85])
            ax.annotate(
                "gravity (when on)",
                xy=tuple(start + 0.15 * g[[0, 2]]),
                xytext=tuple(start),
                xycoords="axes fraction",
                textcoords="axes fraction",
                ha="center",
                va="bottom",
                fontsize=8,
                color="0.3",
                arrowprops=dict(arrowstyle="-|>", color="0.3", lw=1.5),
            )
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    fig.suptitle("Simulated backbones vs the CCKA arcs from their sensed cable lengths")
    return _save(fig, path, dpi)


def fig_resolution(res, path: Path, dpi: int) -> Path:
    p = res.config.params
    fig = _figure(12, 8, dpi)
    (a, b), (c, d) = fig.subplots(2, 2)
    any_sweep = (res.resolution_links or res.resolution_disks)[0]
    f_top = float(any_sweep.forces[-1])
    theta_el = math.degrees(float(statics.arc_from_tensions(cable1_tensions(f_top, p), p)[0]))

    def draw(ax_err, ax_th, sweeps, x, label, style, colour):
        if not sweeps:
            return
        mean = np.array([s.error_norm.mean() for s in sweeps]) * MM
        mx = np.array([s.error_norm.max() for s in sweeps]) * MM
        ax_err.plot(x, mx, style, color=colour, label=f"{label}: max")
        ax_err.plot(x, mean, style, color=colour, alpha=0.45, label=f"{label}: mean")
        ax_th.plot(
            x, np.degrees([s.theta_sim[-1] for s in sweeps]), style, color=colour, label=label
        )

    lps = [s.links_per_span for s in res.resolution_links]
    draw(a, b, res.resolution_links, lps, "gravity off", "o-", "tab:blue")
    draw(
        a,
        b,
        res.resolution_links_on,
        [s.links_per_span for s in res.resolution_links_on],
        "gravity on",
        "s--",
        "tab:orange",
    )
    for ax in (a, b):
        ax.set_xscale("log", base=2)
        ax.set_xticks(lps, [str(k) for k in lps])
        ax.set_xlabel(f"links per disk span ({p.n_disks} disks)")
        ax.grid(alpha=0.3, which="both")
    a.set(
        ylabel="Euclidean CCKA error (mm)",
        title=f"(a) model resolution: CCKA error over 0–{f_top:g} N",
    )
    b.set(
        ylabel="bending angle θ (degrees)",
        title=f"(b) model resolution: bending angle at {f_top:g} N",
    )
    b.axhline(theta_el, color="k", ls=":", label=f"continuous elastica ({theta_el:.1f}°)")
    disks = [s.n_disks for s in res.resolution_disks]
    draw(c, d, res.resolution_disks, disks, "gravity off", "o-", "tab:green")
    for s, n in zip(res.resolution_disks, disks):
        d.annotate(
            f"{s.n_disks}×{s.links_per_span} links",
            (n, math.degrees(s.theta_sim[-1])),
            textcoords="offset points",
            xytext=(4, 4),
            fontsize=7,
        )
    for ax in (c, d):
        ax.set_xscale("log", base=2)
        ax.set_xticks(disks, [str(n) for n in disks])
        ax.set_xlabel("number of spacer disks")
        ax.grid(alpha=0.3, which="both")
    c.set(
        ylabel="Euclidean CCKA error (mm)",
        title=f"(c) number of disks: CCKA error over 0–{f_top:g} N",
    )
    d.set(
        ylabel="bending angle θ (degrees)",
        title=f"(d) number of disks: bending angle at {f_top:g} N",
    )
    d.axhline(theta_el, color="k", ls=":", label=f"continuous elastica ({theta_el:.1f}°)")
    for ax in (a, b, c, d):
        ax.legend(fontsize=7)
    fig.suptitle("Beyond the paper — model resolution and number of spacer disks")
    return _save(fig, path, dpi)
