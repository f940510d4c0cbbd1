"""Structural terms for the FTDCR v4 robot, probed on the CCKA model before any is built
into the backends (docs/experiments/real_robot.md):

* ``anisotropic``: the rod bends more stiffly about one axis of the cross-section than about
  the other, the same for every section: the bending compliance of section j is
  ``R(φ)·diag(1/(1+a), 1/(1−a))·R(φ)ᵀ/EI`` (a ∈ (−1, 1), φ the axis angle from the disk's x
  axis, rad);
* ``anisotropic_sections``: the same with its own (a, φ) per section;
* ``capstan``: tension lost along the path of a tendon through the sections below its own
  (a loss-only capstan law, the tendon being pulled): the tension acting in section j is
  ``T·exp(−μ·Σ_{k<j} θ_k)`` with θ_k the bend angle of section k (a fixed point, 30 damped
  iterations);
* ``backlash_sections`` / ``backlash_tendons``: the drives' play per section / per tendon;
* ``tension_cap``: every tendon's tension capped at one fitted T_max (N; a servo's stall
  torque), starting at 9 N, about the largest tension of the selected fit on train.csv;
* ``softening`` / ``softening_sections``: a drive whose pull saturates smoothly: a tendon
  pulled in by y > 0 (after the play) is pulled by ``d_s·tanh(y/d_s)`` instead (released
  commands unchanged), one d_s (m) for every drive / one per section, starting at 100 mm;
* ``compliance_sections``: an axial give Δc_j ≥ 0 (m/N) of each section under the load that
  passes through it: a tendon ending in section j loses Σ_{k≤j} Δc_k·(load change through
  section k) of its pull (the base compliance is the same give at section 1, where every
  tendon passes);
* ``stiffening``: a rod that stiffens with its curvature, EI·(1 + β·(κ/20 m⁻¹)²) per section
  (a fixed point, 30 damped iterations; β may be negative down to a fivefold softening);
* ``slack_tendons``: every tendon's length offset ℓ_i (m, either sign): it is commanded d − ℓ_i;
* ``through_radius``: one factor on the tendons' radii in the sections they pass through
  (not in their own);
* ``through_pairs``: the same with one factor per (own section, section passed through);
* ``through_angles``: the tendons passing through section 1 / 2 turned by one angle each there;
* ``helix``: tendons wound helically at p (deg per 100 mm of backbone): a tendon passes a
  section below its own turned by p times the distance between the two sections' midpoints;
* ``E_sections``: the Young's moduli of sections 2 and 3 relative to section 1's.
* ``clearance``: the pinholes' play c (m): a taut tendon rests on the side of its hole towards
  the centre of curvature, so in every section it runs through (its own and those below) its
  radius vector is moved by c towards that centre: its path shortens by c·θ_j more and its
  moment gains c·T along the bend (consistent: the same shifted radius in both; a fixed point
  on the bend directions, iterated until they change by less than 1e-12, at most 200 times).

Terms combine with ``+`` (``anisotropic_sections+softening``).

Each is started from the CCKA fit of the selected set with parallel tendons
(``ftdcr_v4_ccka_selected``, the selection's choice before the helix was a candidate: its
tendon angles, pretensions and backlash kept) and fitted together with the base frame, the marker offset, E
and the base compliance — the term's parameters start at zero (φ at 0°, μ at 0.05, the cap
and d_s as above, each section's give at 1e-6 m/N) — first on the one-tendon and
one-section rows of train.csv and scored on its two-section rows (the selection split of
``configs/calibration/ftdcr_v4_ccka_selection.py``), then on all of train.csv and replayed
on val.csv, scored on all its rows and apart on the rows that command
some tendon beyond its range over train.csv (``beyond``) and the others (``inside``).
``isotropic`` is the same refit without a term.

Usage: python -m experiments.ftdcr_v4_structure_probes [--terms a,b+c] [--warm]   (aligned RMSEs
in mm; ~3 min for every single term; ``--warm``: a combination b+c starts from the fits of b)
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from cdcr_gym.calibration import Measurements, read_csv
from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.drive import DriveGeometry, TendonDrive, forward_tips
from cdcr_gym.calibration.report import load_fitted
from cdcr_gym.calibration.simulate import drive_geometry
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.params_yaml import load_yaml
from cdcr_gym.model.tendons import solve_tendon_law

FIT = Path("docs/figures/calibration/ftdcr_v4_ccka_selected/params.yaml")
DATA = Path("data/real/ftdcr_v4")
#: parameters of every refit: frame (mm, deg), marker (mm), ln(E/E₀), compliance (1e-5 m/N)
N_COMMON = 9


def section_compliance(ei: float, anisotropy: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The block-diagonal bending compliance (2S, 2S) 1/(N·m²) of S sections with bending
    stiffness ``ei`` N·m², anisotropies a (S,) in (−1, 1) and axis angles φ (S,) rad: block j
    is ``R(φ_j)·diag(1/(1+a_j), 1/(1−a_j))·R(φ_j)ᵀ/EI`` (a = 0: ``I/EI``)."""
    s = len(anisotropy)
    out = np.zeros((2 * s, 2 * s))
    for j, (a, phi) in enumerate(zip(anisotropy, axes)):
        c, sn = np.cos(phi), np.sin(phi)
        rot = np.array([[c, -sn], [sn, c]])
        out[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] = (
            rot @ np.diag([1.0 / (1.0 + a), 1.0 / (1.0 - a)]) @ rot.T / ei
        )
    return out


def solve_curvatures(
    geom: DriveGeometry,
    d: np.ndarray,
    compliance: np.ndarray,
    mu: float = 0.0,
    max_tension: float | None = None,
    section_compliance_extra: np.ndarray | None = None,
    stiffening: float = 0.0,
    through_scale: float | np.ndarray = 1.0,
    through_rotation: np.ndarray | None = None,
    clearance: float = 0.0,
) -> np.ndarray:
    """Section curvatures (M, S, 2) 1/m of the first robot of ``geom`` under commands ``d``
    (M, C) m (already through the drives' play) with the bending compliance (2S, 2S) and a
    loss-only capstan coefficient ``mu`` (module docstring; 0: none). The drive law and its
    solver are the library's (:func:`cdcr_gym.model.tendons.solve_tendon_law`); with an
    isotropic compliance and ``mu = 0`` this is :func:`cdcr_gym.calibration.drive.solve_drive`.
    ``section_compliance_extra`` (S,) m/N ≥ 0: an axial give of each section under the load
    that passes through it (term ``compliance_sections``; the base compliance is section 0's).
    ``through_scale`` (a factor or (S, S) factors [own section, section passed through]) scales
    and ``through_rotation`` ((S,) per section passed through or (S, S) as the factors) rad turns
    the radius vectors of the tendons in the sections they
    pass through (terms ``through_radius``, ``through_pairs``, ``through_angles``).
    ``clearance`` (m): the pinholes' play (term ``clearance``).
    """
    g, lam = geom.coupling()
    g, lam = g[0], lam[0]  # (C, 2S), (2S,)
    rows, c = d.shape
    s = g.shape[1] // 2
    factors = np.broadcast_to(np.asarray(through_scale, dtype=float), (s, s))
    turns = np.zeros((s, s)) if through_rotation is None else np.asarray(through_rotation)
    turns = turns if turns.ndim == 2 else np.broadcast_to(turns[None, :], (s, s))
    if np.any(factors != 1.0) or np.any(turns != 0.0):
        g = g.copy()
        section_of = np.asarray(geom.section_of)
        for j in range(s):
            through = section_of > j
            turn = turns[section_of[through], j]
            cr, sr = np.cos(turn), np.sin(turn)
            gx, gy = g[through, 2 * j].copy(), g[through, 2 * j + 1].copy()
            f = factors[section_of[through], j]
            g[through, 2 * j] = f * (cr * gx - sr * gy)
            g[through, 2 * j + 1] = f * (sr * gx + cr * gy)
    comp = 0.0 if geom.base_compliance is None else float(geom.base_compliance[0])
    pre = np.maximum(geom.pretension[0], 0.0)
    extra = np.zeros((c, c))
    if section_compliance_extra is not None:
        section_of = np.asarray(geom.section_of)
        for j, cj in enumerate(section_compliance_extra):
            through = (section_of >= j).astype(float)
            extra += cj * np.outer(through, through)
        d = d + pre @ extra
    att = np.ones((rows, c, s))
    soft = np.ones((rows, s))  # the rows' bending compliance factors per section
    # (C, S): tendon i runs through section j (its own or one below it)
    runs = (np.asarray(geom.section_of)[:, None] >= np.arange(s)[None, :]).astype(float)
    towards = np.zeros((rows, s, 2))  # unit bend directions (M, S, 2) of the last iterate
    iterate = mu > 0.0 or stiffening != 0.0 or clearance != 0.0
    for _it in range(200 if clearance != 0.0 else 30 if iterate else 1):
        shift = clearance * runs[None, :, :, None] * towards[:, None, :, :]  # (M, C, S, 2)
        gc = g[None] + shift.reshape(rows, c, 2 * s)
        geff = gc * np.repeat(att, 2, axis=2)  # (M, C, 2S): the tension acting per section
        comp_rows = compliance[None] * np.repeat(soft, 2, axis=1)[:, :, None]  # (M, 2S, 2S)
        m_rows = np.einsum("mcp,mpq,mkq->mck", gc * lam[None, None], comp_rows, geff) + extra[None]
        t, _ = solve_tendon_law(
            m_rows,
            d,
            geom.stiffness[0],
            pre,
            max_tension,
            1e-12,
            100,
            base_compliance=comp,
        )
        u = np.einsum("mpq,mkq,mk->mp", comp_rows, geff, t)
        if stiffening != 0.0:
            kappa = np.hypot(u[:, 0::2], u[:, 1::2])  # (M, S) 1/m
            soft = 0.5 * soft + 0.5 / np.maximum(1.0 + stiffening * (kappa / 20.0) ** 2, 0.2)
        if clearance != 0.0:
            uu = u.reshape(rows, s, 2)
            norm = np.linalg.norm(uu, axis=2, keepdims=True)
            new = np.divide(uu, norm, out=np.zeros_like(uu), where=norm > 1e-9)
            change = float(np.max(np.abs(new - towards)))
            towards = new
            if change < 1e-12 and mu == 0.0 and stiffening == 0.0:
                break
        if not iterate:
            break
        theta = np.hypot(u[:, 0::2], u[:, 1::2]) * lam[None, 0::2]  # (M, S) rad
        wrap = np.concatenate([np.zeros((rows, 1)), np.cumsum(theta, axis=1)[:, :-1]], axis=1)
        att = 0.5 * att + 0.5 * np.repeat(np.exp(-mu * wrap)[:, None, :], c, axis=1)
    return u.reshape(rows, s, 2)


class Probe:
    """The selected CCKA fit with one structural term (module docstring), as a function of the
    scaled parameters p: predicted tips (M, 3) m of a measurement file."""

    TERMS = {
        "isotropic": 0,
        "anisotropic": 2,
        "anisotropic_sections": 6,
        "capstan": 1,
        "backlash_sections": 3,
        "backlash_tendons": 9,
        "tension_cap": 1,
        "softening": 1,
        "softening_sections": 3,
        "compliance_sections": 3,
        "stiffening": 1,
        "slack_tendons": 9,
        "through_radius": 1,
        "through_pairs": 3,
        "through_angles": 2,
        "helix": 1,
        "E_sections": 2,
        "clearance": 1,
    }

    #: the start of the tension cap (N): about the largest tension of the selected fit on train.csv
    CAP_START = 9.0

    def __init__(self, term: str, robot: RobotParams, drive: TendonDrive, values: dict):
        parts = term.split("+")
        for part in parts:
            if part not in self.TERMS or parts.count(part) > 1:
                raise ValueError(
                    f"term must be one of {sorted(self.TERMS)} or several joined by '+', "
                    f"got {term!r}"
                )
        self.term, self.robot, self.drive, self.values = term, robot, drive, values
        self.slices: dict[str, slice] = {}
        at = N_COMMON
        for part in parts:
            self.slices[part] = slice(at, at + self.TERMS[part])
            at += self.TERMS[part]
        self.size = at

    def start(self) -> np.ndarray:
        p = np.zeros(self.size)
        for part, sl in self.slices.items():
            if part == "capstan":
                p[sl] = 0.5  # μ = 0.05
            elif part.startswith("softening"):
                p[sl] = 1.0  # d_s = 100 mm
            elif part == "compliance_sections":
                p[sl] = 0.1  # 1e-6 m/N
            elif part == "clearance":
                p[sl] = 0.5  # 0.05 mm
        return p

    def __call__(self, data: Measurements, p: np.ndarray) -> np.ndarray:
        v0, v = self.values, dict(self.values)
        for i, key in enumerate(("base_x", "base_y", "base_z")):
            v[key] = v0[key] + p[i] * 1e-3
        for i, key in enumerate(("base_yaw", "base_tilt_x", "base_tilt_y")):
            v[key] = v0.get(key, 0.0) + np.radians(p[3 + i])
        v["marker_offset"] = v0["marker_offset"] + p[6] * 1e-3
        v["youngs_modulus"] = self.robot.youngs_modulus * np.exp(p[7])
        v["base_compliance"] = max(0.0, v0.get("base_compliance", 0.0) + p[8] * 1e-5)
        geom = drive_geometry(self.robot, self.drive, [v])
        s = self.robot.n_sections
        section_of = np.asarray(self.robot.cable_section)
        q = {part: p[sl] for part, sl in self.slices.items()}
        a, phi, mu, cap = np.zeros(s), np.zeros(s), 0.0, None
        if "anisotropic" in q:
            a[:], phi[:] = np.tanh(q["anisotropic"][0]), np.radians(q["anisotropic"][1])
        if "anisotropic_sections" in q:
            a = np.tanh(q["anisotropic_sections"][0::2])
            phi = np.radians(q["anisotropic_sections"][1::2])
        if "capstan" in q:
            mu = abs(q["capstan"][0]) * 0.1
        if "tension_cap" in q:
            cap = self.CAP_START * np.exp(q["tension_cap"][0])
        width = np.full(self.robot.n_cables, v["drive_backlash"])
        if "backlash_sections" in q:
            width = np.maximum(0.0, width + q["backlash_sections"][section_of] * 1e-4)
        if "backlash_tendons" in q:
            width = np.maximum(0.0, width + q["backlash_tendons"] * 1e-4)
        assert data.displacements is not None
        d = play(data.displacements, width)
        if "slack_tendons" in q:
            d = d - q["slack_tendons"] * 1e-4
        for part in ("softening", "softening_sections"):
            if part in q:
                d_s = 0.1 / np.maximum(np.abs(q[part]), 1e-6)  # m
                d_s = d_s[section_of] if len(d_s) > 1 else d_s[0]
                d = np.where(d > 0.0, d_s * np.tanh(d / d_s), d)
        beta = float(q["stiffening"][0]) if "stiffening" in q else 0.0
        extra = None
        if "compliance_sections" in q:
            extra = np.abs(q["compliance_sections"]) * 1e-5
        compliance = section_compliance(float(geom.ei[0]), a, phi)
        if "E_sections" in q:  # sections 2 and 3 relative to section 1
            f = np.repeat(np.exp(-np.concatenate([[0.0], q["E_sections"]])), 2)
            compliance = compliance * f[:, None]
        u = solve_curvatures(
            geom,
            d,
            compliance,
            mu,
            max_tension=cap,
            section_compliance_extra=extra,
            stiffening=beta,
            through_scale=self._through_scale(q, s),
            through_rotation=self._through_rotation(q, s),
            clearance=abs(float(q["clearance"][0])) * 1e-4 if "clearance" in q else 0.0,
        )
        return forward_tips(geom, u[None])[0][0]

    @staticmethod
    def _through_scale(q: dict, s: int) -> float | np.ndarray:
        """The through-radius factors of the terms ``through_radius`` / ``through_pairs``."""
        factor: float | np.ndarray = 1.0
        if "through_radius" in q:
            factor = float(np.exp(q["through_radius"][0]))
        if "through_pairs" in q:  # (own, through): (2, 1), (3, 1), (3, 2) of a 3-section robot
            pairs = np.ones((s, s))
            for (own, thr), x in zip(((1, 0), (2, 0), (2, 1)), q["through_pairs"]):
                pairs[own, thr] = np.exp(x)
            factor = factor * pairs
        return factor

    def _through_rotation(self, q: dict, s: int) -> np.ndarray | None:
        """The turns (S, S) rad [own section, section passed through] of the terms
        ``through_angles`` / ``helix``."""
        if "through_angles" not in q and "helix" not in q:
            return None
        turns = np.zeros((s, s))
        if "through_angles" in q:
            turns += np.radians(np.append(q["through_angles"], 0.0))[None, :]
        if "helix" in q:  # pitch p (deg per 100 mm): p·(mid(own) − mid(through))
            lengths = np.asarray(self.robot.section_lengths)
            mid = np.cumsum(lengths) - 0.5 * lengths
            turns += np.radians(q["helix"][0] * 10.0) * (mid[:, None] - mid[None, :])
        return turns

    def fit(self, data: Measurements, start: np.ndarray | None = None) -> np.ndarray:
        """Least squares on the tip residuals (mm) from ``start`` (None: :meth:`start`)."""
        return least_squares(
            lambda p: (self(data, p) - data.tip).ravel() * 1e3,
            self.start() if start is None else start,
            diff_step=1e-3,
            max_nfev=200,
        ).x

    def describe(self, p: np.ndarray) -> str:
        return "; ".join(self._describe(part, p[sl]) for part, sl in self.slices.items())

    def _describe(self, part: str, q: np.ndarray) -> str:
        if part == "anisotropic":
            return f"a = {np.tanh(q[0]):+.3f}, φ = {q[1]:.1f}°"
        if part == "anisotropic_sections":
            return ", ".join(
                f"s{j + 1}: a = {np.tanh(q[2 * j]):+.3f}, φ = {q[2 * j + 1]:.1f}°"
                for j in range(len(q) // 2)
            )
        if part == "capstan":
            return f"μ = {abs(q[0]) * 0.1:.4f}"
        if part == "E_sections":
            return "E2/E1, E3/E1 = " + " / ".join(f"{np.exp(x):.3f}" for x in q)
        if part == "through_pairs":
            return "through factors (2 in 1, 3 in 1, 3 in 2) = " + " / ".join(
                f"{np.exp(x):.3f}" for x in q
            )
        if part == "helix":
            return f"helix pitch {q[0]:+.2f}°/100 mm"
        if part == "through_angles":
            return "through turns (in 1, in 2) = " + " / ".join(f"{x:+.1f}°" for x in q)
        if part == "clearance":
            return f"pinhole play c = {abs(q[0]) * 0.1:.3f} mm"
        if part == "through_radius":
            return f"through-radius factor {np.exp(q[0]):.3f}"
        if part == "slack_tendons":
            return "ℓ = " + " / ".join(f"{x * 0.1:+.2f}" for x in q) + " mm"
        if part == "stiffening":
            return f"β = {q[0]:+.3f} (EI·(1 + β·(κ/20 m⁻¹)²))"
        if part == "compliance_sections":
            return "Δc = " + " / ".join(f"{abs(x) * 10:.2f}" for x in q) + " (1e-6 m/N)"
        if part == "tension_cap":
            return f"T_max = {self.CAP_START * np.exp(q[0]):.2f} N"
        if part.startswith("softening"):
            return "d_s = " + " / ".join(f"{100 / max(abs(x), 1e-6):.1f}" for x in q) + " mm"
        if part.startswith("backlash"):
            w = np.maximum(0.0, self.values["drive_backlash"] + q * 1e-4) * 1e3
            return "w = " + " / ".join(f"{x:.3f}" for x in w) + " mm"
        return ""


def rmse_aligned(pred: np.ndarray, tip: np.ndarray) -> float:
    """Aligned RMSE (mm): the mean offset of the set removed."""
    e = pred - tip
    e = e - e.mean(axis=0)
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))) * 1e3)


def rmse_aligned_split(pred: np.ndarray, tip: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """The aligned RMSE (mm) of the rows outside and inside ``mask`` (M,) bool, the mean offset
    of the whole set removed (as :func:`rmse_aligned`)."""
    e = pred - tip
    sq = np.sum((e - e.mean(axis=0)) ** 2, axis=1)
    return float(np.sqrt(sq[~mask].mean()) * 1e3), float(np.sqrt(sq[mask].mean()) * 1e3)


def _is_pair(label: str) -> bool:
    return re.sub(r"^rep\d+_", "", label).startswith("pair")


def selected_fit() -> tuple[RobotParams, TendonDrive, dict[str, float]]:
    """The robot, tendon drive and the frame, marker, backlash and base-compliance values of
    the selected CCKA fit every probe starts from (``FIT``)."""
    robot, _ = load_fitted(FIT)
    drive = TendonDrive.of(robot)
    if drive is None:  # pragma: no cover - the fit has its drive
        raise ValueError(f"{FIT}: no calibration.tendons")
    fitted = load_yaml(FIT)["calibration"]["fitted"]
    values = {
        k: float(v)
        for k, v in fitted.items()
        if k.startswith(("base_", "marker")) or k in ("drive_backlash", "base_compliance")
    }
    return robot, drive, values


def run(
    terms: list[str], report: Callable[[str], None] = print, warm: bool = False
) -> dict[str, dict]:
    """Fit every term on the selection split and on train.csv (module docstring). ``warm``: a
    combination ``a+…+z`` starts from the fits of ``a+…`` (z's parameters at their start)."""
    robot, drive, values = selected_fit()
    train = read_csv(DATA / "train.csv", robot=robot, drive=drive)
    val = read_csv(DATA / "val.csv", robot=robot, drive=drive)
    pair = np.array([_is_pair(lab) for lab in train.labels])
    single, pairs = train.subset(np.flatnonzero(~pair)), train.subset(np.flatnonzero(pair))
    assert train.displacements is not None and val.displacements is not None
    beyond = np.any(val.displacements > train.displacements.max(axis=0), axis=1)
    out = {}
    for term in terms:
        t0 = time.perf_counter()
        probe = Probe(term, robot, drive, values)
        starts: list[np.ndarray | None] = [None, None]
        if warm and "+" in term:
            first = Probe(term.rsplit("+", 1)[0], robot, drive, values)
            tail = probe.start()[first.size :]
            starts = [np.append(first.fit(part), tail) for part in (single, train)]
        ps, pf = probe.fit(single, starts[0]), probe.fit(train, starts[1])
        val_pred = probe(val, pf)
        inside, outside = rmse_aligned_split(val_pred, val.tip, beyond)
        row = {
            "single": rmse_aligned(probe(single, ps), single.tip),
            "pairs": rmse_aligned(probe(pairs, ps), pairs.tip),
            "train": rmse_aligned(probe(train, pf), train.tip),
            "val": rmse_aligned(val_pred, val.tip),
            "val_inside": inside,
            "val_beyond": outside,
            "selection_fit": probe.describe(ps),
            "full_fit": probe.describe(pf),
            "seconds": round(time.perf_counter() - t0, 1),
        }
        out[term] = row
        report(
            f"{term}: single {row['single']:.3f}, pairs {row['pairs']:.3f} | train "
            f"{row['train']:.3f}, held-out {row['val']:.3f} (inside {row['val_inside']:.3f}, "
            f"beyond {row['val_beyond']:.3f}) mm | {row['full_fit']} "
            f"(on the single rows: {row['selection_fit']}) "
            f"({row['seconds']:.0f} s)"
        )
    return out


def main(argv: list[str] | None = None) -> None:
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_structure_probes",
        description=__doc__.splitlines()[0],
    )
    parser.add_argument("--terms", default=",".join(Probe.TERMS), help="comma-separated terms")
    parser.add_argument(
        "--warm",
        action="store_true",
        help="start a combination a+b from the fits of a (b's parameters at their start)",
    )
    args = parser.parse_args(argv)
    run(args.terms.split(","), warm=args.warm)


if __name__ == "__main__":
    main()
