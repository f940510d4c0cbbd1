"""Calibration on displacement-driven robots: the measurement files (own and published format),
the CCKA drive model, the fit names, held-out validation, report.json, the real FTDCR v4 data
and the synthetic recovery."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from cdcr_gym.calibration import Measurements, calibrate, read_csv, write_outputs
from cdcr_gym.calibration.drive import TendonDrive, forward_tips, solve_drive
from cdcr_gym.calibration.parameters import expand_names, resolve_names
from cdcr_gym.calibration.report import report_json
from cdcr_gym.calibration.simulate import DriveReplay, drive_geometry
from cdcr_gym.model.params import RobotParams
from training.studies import calibrate as cli

REAL = Path(__file__).resolve().parents[2] / "data" / "real" / "ftdcr_v4"
V4 = RobotParams.preset("ftdcr_v4")
V4_DRIVE = TendonDrive.of(V4)
HEADER = (
    "timestamp,pattern_label,servo_4_mm,servo_3_mm,servo_9_mm,servo_5_mm,servo_2_mm,"
    "servo_8_mm,servo_6_mm,servo_1_mm,servo_7_mm,tip_x,tip_y,tip_z\n"
)
ROW = "{t},p,{d},0,0,0,0,0,0,0,-1,-2.0,8.0,{z}\n"


def _published(tmp_path: Path, text: str, name: str = "pub.csv", bom: bool = False) -> Path:
    path = tmp_path / name
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    return path


def test_published_format_is_read_in_si_with_timing(tmp_path):
    text = HEADER + ROW.format(t=10.0, d=1.5, z=187.0) + ROW.format(t=10.5, d=-10, z=186.0)
    data = read_csv(_published(tmp_path, text, bom=True), robot=V4, drive=V4_DRIVE)
    assert data.displacements is not None and data.tensions is None
    np.testing.assert_allclose(data.displacements[0, :2], [1.5e-3, 0.0])
    np.testing.assert_allclose(data.displacements[1, 0], -0.010)
    np.testing.assert_allclose(data.tip[0], [-2e-3, 8e-3, 0.187])
    np.testing.assert_allclose(data.timestamps, [10.0, 10.5])
    assert list(data.lines) == [2, 3] and data.labels == ("p", "p")
    # the explicit flag gives the same
    again = read_csv(_published(tmp_path, text), "published", V4, V4_DRIVE)
    np.testing.assert_array_equal(again.displacements, data.displacements)


def test_own_format_with_displacement_columns(tmp_path):
    cols = ",".join(f"d{i + 1}" for i in range(9))
    path = tmp_path / "own.csv"
    path.write_text(f"{cols},x,y,z,timestamp\n" + "0.001," * 9 + "0.0,0.0,0.18,1.0\n")
    data = read_csv(path, robot=V4, drive=V4_DRIVE)
    np.testing.assert_allclose(data.displacements, np.full((1, 9), 1e-3))
    np.testing.assert_allclose(data.timestamps, [1.0])


@pytest.mark.parametrize(
    "text, message",
    [
        (HEADER.replace(",servo_7_mm", "") + "1,p,0,0,0,0,0,0,0,0,0,0,180\n", "8 servo column"),
        (HEADER + ROW.format(t=1, d="abc", z=180), "pub.csv line 2, column 'servo_4_mm'.*abc"),
        (HEADER + ROW.format(t=1, d="nan", z=180), "pub.csv line 2, column 'servo_4_mm'.*finite"),
        (
            HEADER + ROW.format(t=1, d=0, z=180) + ROW.format(t=2, d=0.0, z=180000),
            "pub.csv line 3, column 'tip_z'.*mm vs m",
        ),
        (HEADER + ROW.format(t=1, d=0, z=0.18), "pub.csv line 2, column 'tip_z'.*m vs mm"),
        (HEADER + ROW.format(t=1, d=500, z=180), "pub.csv line 2, column 'servo_4_mm'.*500"),
        (
            HEADER + ROW.format(t=2, d=0, z=180) + ROW.format(t=1, d=0, z=180),
            "pub.csv line 3, column 'timestamp'",
        ),
    ],
)
def test_malformed_published_files_name_file_line_column(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        read_csv(_published(tmp_path, text), robot=V4, drive=V4_DRIVE)


def test_own_format_mm_mixup_is_caught(tmp_path):
    cols = ",".join(f"d{i + 1}" for i in range(9))
    path = tmp_path / "own.csv"
    path.write_text(f"{cols},x,y,z\n" + "0.001," * 8 + "4.0,0.0,0.0,0.18\n")  # 4 "m"
    with pytest.raises(ValueError, match="own.csv line 2, column 'd9'.*mm vs m"):
        read_csv(path, robot=V4, drive=V4_DRIVE)


def test_drive_solver_matches_the_model_solver():
    """The calibration's batched solver equals cdcr_gym.model.tendons on the v4 robot."""
    from cdcr_gym.model.statics import cached_model
    from cdcr_gym.model.tendons import solve_displacement_statics

    rng = np.random.default_rng(0)
    d = rng.uniform(-0.01, 0.008, (50, 9))
    k = np.array(V4_DRIVE.stiffness)
    t0 = np.array(V4_DRIVE.pretension)
    ref = solve_displacement_statics(cached_model(V4), d, k, t0, np.inf)
    geom = drive_geometry(V4, V4_DRIVE, [{}])
    ours = solve_drive(geom, d)
    np.testing.assert_allclose(ours.tensions[0], ref.tensions, rtol=1e-7, atol=1e-7)
    np.testing.assert_array_equal(ours.slack[0], ref.slack)
    assert ours.slack.any() and (~ours.slack).any()


@pytest.mark.parametrize(
    ("slack", "cap"), [(True, np.inf), (True, 4.0), (False, np.inf), (False, 4.0)]
)
def test_drive_solver_is_the_equilibrium_of_each_robot(slack, cap):
    """Robots of different geometry in one batch: every row satisfies the drive law and the
    moment balance EI·u = Gᵀ·T (module docstring of calibration.drive) to round-off."""
    rng = np.random.default_rng(1)
    batch = [
        {
            "length_s2": 0.07,
            "cable_radius_s1": 0.005,
            "section_angle_s3": 0.2,
            "youngs_modulus": 4e10,
            "tendon_pretension": 1.5,
        },
        {"tendon_stiffness_4": 3000.0, "cable_angle_2": -0.1},
        {},
    ]
    geom = drive_geometry(V4, V4_DRIVE, batch, slack=slack)
    geom.max_tension = cap
    d = rng.uniform(-0.008, 0.008, (40, 9))
    st = solve_drive(geom, d)
    g, lam = geom.coupling()
    u = st.curvature.reshape(len(batch), 40, -1)
    s = np.einsum("bcn,bmn->bmc", g * lam[:, None, :], u)
    raw = geom.pretension[:, None, :] + geom.stiffness[:, None, :] * (d[None] - s)
    law = np.clip(raw, 0.0 if slack else -np.inf, cap)
    np.testing.assert_allclose(st.tensions, law, atol=1e-9)
    balance = geom.ei[:, None, None] * u - np.einsum("bcn,bmc->bmn", g, st.tensions)
    assert np.max(np.abs(balance)) < 1e-12
    np.testing.assert_allclose(st.shortening, s, atol=1e-15)
    if slack:  # slack tendons exist and carry exactly nothing
        assert st.slack.any() and np.all(st.tensions[st.slack] == 0.0)
    else:  # the linear law pushes
        assert np.any(st.tensions < 0.0)
    if np.isfinite(cap):
        assert st.saturated.any() and np.all(st.tensions <= cap)


def test_tendon_law_solver_rejects_bad_input():
    from cdcr_gym.model.tendons import solve_tendon_law

    m = np.eye(3)[None] * 1e-5
    with pytest.raises(ValueError, match="shortening_matrices"):
        solve_tendon_law(np.eye(3), np.zeros((1, 3)), 1.0, 0.0)
    with pytest.raises(ValueError, match="displacements"):
        solve_tendon_law(m, np.zeros((2, 3)), 1.0, 0.0)
    with pytest.raises(ValueError, match="stiffness"):
        solve_tendon_law(m, np.zeros((1, 3)), np.inf, 0.0)
    with pytest.raises(ValueError, match="pretension"):
        solve_tendon_law(m, np.zeros((1, 3)), 1.0, -1.0)
    t, _ = solve_tendon_law(m, np.array([[0.001, -0.001, 0.0]]), 1000.0, 0.5)
    # decoupled tendons: T = (T0 + k·d)/(1 + k·m) when taut; the second one is slack
    np.testing.assert_allclose(t, [[1.5 / 1.01, 0.0, 0.5 / 1.01]], rtol=1e-12)


def test_forward_tips_one_section_is_the_arc_formula():
    from cdcr_gym import kinematics as K

    p = RobotParams()
    geom = drive_geometry(p, TendonDrive((1e3,) * 3, (0.0,) * 3), [{}])
    theta, phi = 1.1, 0.7
    kappa = theta / p.length * np.array([np.cos(phi), np.sin(phi)])
    tip, tangent = forward_tips(geom, kappa.reshape(1, 1, 1, 2))
    np.testing.assert_allclose(tip[0, 0], K.tip_from_arc(theta, phi, p.length), atol=1e-12)
    assert abs(np.linalg.norm(tangent[0, 0]) - 1.0) < 1e-12


def test_fit_names_aliases_overlaps_and_pins():
    names = expand_names("base_frame,marker,k_sections,T0", V4)
    assert names[:7] == [
        "base_x",
        "base_y",
        "base_z",
        "base_tilt_x",
        "base_tilt_y",
        "base_yaw",
        "marker_offset",
    ]
    assert "tendon_stiffness_s3" in names and "tendon_pretension" in names
    with pytest.raises(ValueError, match="both set the same quantity"):
        resolve_names("k,tendon_stiffness_s1", V4)
    with pytest.raises(ValueError, match="both set the same quantity"):
        resolve_names("section_angle_s1,cable_angle_2", V4)
    with pytest.raises(ValueError, match="ccka"):
        from cdcr_gym.calibration.simulate import backend_class

        resolve_names("base_x", V4, backend_class("mujoco"), "mujoco")


def _synthetic(truth: dict, n: int = 150, sigma: float = 0.0, seed: int = 1) -> Measurements:
    rng = np.random.default_rng(seed)
    d = rng.uniform(-0.006, 0.006, (n, 9))
    template = Measurements(None, np.zeros((n, 3)), None, None, displacements=d)
    tip = DriveReplay(template, V4, V4_DRIVE)(truth).tip
    tip = tip + rng.normal(0.0, sigma, tip.shape)
    return Measurements(None, tip, None, None, displacements=d)


TRUTH = {
    "youngs_modulus": 0.9 * V4.youngs_modulus,
    "tendon_stiffness": 5000.0,
    "tendon_pretension": 2.0,
    "base_x": 0.8e-3,
    "base_y": -0.5e-3,
    "base_z": 1.2e-3,
    "base_tilt_x": 0.02,
    "base_tilt_y": -0.01,
    "base_yaw": 0.03,
}


@pytest.mark.parametrize("known", ["tendon_stiffness", "youngs_modulus"])
def test_synthetic_recovery_of_stiffness_pretension_and_base_frame(known):
    """E, k and T0 scaled together leave every shape unchanged, so one of E and k is known;
    the others are recovered: E within 2 %, k and T0 within 5 %, base within 0.3 mm."""
    data = _synthetic(TRUTH, sigma=0.05e-3)
    free = [n for n in TRUTH if n != known]
    start: dict[str, float] = {}
    drive = TendonDrive(
        (TRUTH["tendon_stiffness"] if known == "tendon_stiffness" else V4_DRIVE.stiffness[0],) * 9,
        (0.5,) * 9,
        V4_DRIVE.displacement_range,
    )
    base = (
        V4
        if known != "youngs_modulus"
        else RobotParams.preset("ftdcr_v4", youngs_modulus=TRUTH["youngs_modulus"], max_tension=8.0)
    )
    res = calibrate(data, base, free, "ccka", drive=drive, start=start)
    v = res.values
    if "youngs_modulus" in v:
        assert abs(v["youngs_modulus"] / TRUTH["youngs_modulus"] - 1) < 0.02
    if "tendon_stiffness" in v:
        assert abs(v["tendon_stiffness"] / TRUTH["tendon_stiffness"] - 1) < 0.05
    assert abs(v["tendon_pretension"] / TRUTH["tendon_pretension"] - 1) < 0.05
    for n in ("base_x", "base_y", "base_z"):
        assert abs(v[n] - TRUTH[n]) < 0.3e-3, n


def test_e_k_t0_together_pin_e():
    data = _synthetic(TRUTH, n=30)
    res = calibrate(data, V4, "E,k,T0", "ccka", drive=V4_DRIVE)
    assert "youngs_modulus" not in res.names
    assert any("pinned youngs_modulus" in n for n in res.notes)


def test_validation_never_touches_the_fit_and_report_json(tmp_path):
    data = _synthetic(TRUTH, n=40)
    val_a = _synthetic(TRUTH, n=20, seed=5)
    val_b = Measurements(None, val_a.tip + 0.01, None, None, displacements=val_a.displacements)
    names = "base_translation,T0"
    ra = calibrate(data, V4, names, "ccka", drive=V4_DRIVE, validate=val_a)
    rb = calibrate(data, V4, names, "ccka", drive=V4_DRIVE, validate=val_b)
    assert ra.values == rb.values
    doc_a, doc_b = report_json(ra), report_json(rb)
    assert doc_a["validation"]["rmse_aligned_mm"] == pytest.approx(
        doc_b["validation"]["rmse_aligned_mm"], abs=1e-9
    )  # a common offset is aligned away
    assert doc_b["validation"]["mean_mm"] > doc_a["validation"]["mean_mm"] + 10.0
    paths = write_outputs(ra, tmp_path / "out")
    doc = json.loads(paths["json"].read_text())
    assert set(doc) == {"train", "validation", "backend", "fitted", "seconds"}
    assert set(doc["train"]) == {"rmse_aligned_mm", "mean_mm"}
    assert set(doc["validation"]) == {
        "rmse_aligned_mm",
        "mean_mm",
        "median_mm",
        "p95_mm",
        "percent_of_length",
    }
    assert doc["backend"] == "ccka" and set(doc["fitted"]) == set(ra.names)
    assert {p.name for p in (tmp_path / "out").iterdir()} == {
        "params.yaml",
        "report.md",
        "residuals.png",
        "report.json",
    }


def test_outputs_are_atomic(tmp_path, monkeypatch):
    from cdcr_gym.calibration import report

    data = _synthetic(TRUTH, n=20)
    res = calibrate(data, V4, "base_z", "ccka", drive=V4_DRIVE)

    def broken(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(report, "plot_residuals", broken)
    with pytest.raises(RuntimeError):
        write_outputs(res, tmp_path / "out")
    assert list(tmp_path.iterdir()) == []
    # into an existing folder: an error leaves it as it was; success keeps other files
    out = tmp_path / "existing"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(RuntimeError):
        write_outputs(res, out)
    assert [p.name for p in tmp_path.iterdir()] == ["existing"]
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    monkeypatch.undo()
    write_outputs(res, out)
    assert {p.name for p in out.iterdir()} == {
        "notes.txt",
        "params.yaml",
        "report.md",
        "residuals.png",
        "report.json",
    }


def test_cli_start_values_are_checked(tmp_path, capsys):
    train = REAL / "train.csv"
    for start, message in (
        ("k=-5", "must be > 0"),
        ("lengths=0", "must be > 0"),
        ("nope=1", "unknown parameter"),
    ):
        with pytest.raises(SystemExit) as exc:
            cli.main(
                [
                    str(train),
                    "--robot",
                    "ftdcr_v4",
                    "--backend",
                    "ccka",
                    "--fit",
                    "k,lengths",
                    "--start",
                    start,
                    "--out",
                    str(tmp_path / "o"),
                ]
            )
        assert exc.value.code == 2
        assert message in capsys.readouterr().err


def test_real_data_subset_fits_fast(tmp_path):
    """≤ 100 rows of the FTDCR v4 training file, a few parameters, in < 10 s."""
    train = read_csv(REAL / "train.csv", robot=V4, drive=V4_DRIVE)
    val = read_csv(REAL / "val.csv", robot=V4, drive=V4_DRIVE)
    sub = train.subset(slice(0, None, 17))
    assert len(sub) <= 100
    t0 = time.perf_counter()
    res = calibrate(sub, V4, "base_frame,marker,k", "ccka", validate=val.subset(slice(0, None, 5)))
    assert time.perf_counter() - t0 < 10.0
    doc = report_json(res)
    before = np.linalg.norm(res.before.tip - sub.tip, axis=1).mean() * 1e3
    assert doc["train"]["mean_mm"] < before
    assert doc["validation"]["rmse_aligned_mm"] < 12.0


@pytest.mark.slow
def test_real_data_full_fit_meets_the_published_error(tmp_path):
    """The README's command: validation aligned RMSE <= 7.7 mm (the authors' MuJoCo fit), and
    <= 6.0 mm with the compliant base and the drive backlash (measured 5.72 mm; 6.31 mm
    without the backlash)."""
    out = tmp_path / "v4"
    code = cli.main(
        [
            str(REAL / "train.csv"),
            "--robot",
            "ftdcr_v4",
            "--backend",
            "ccka",
            "--validate",
            str(REAL / "val.csv"),
            "--fit",
            "base_frame,marker,E,T0_tendons,cable_angles,base_compliance,drive_backlash",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0
    doc = json.loads((out / "report.json").read_text())
    assert doc["validation"]["rmse_aligned_mm"] <= 6.0
    assert doc["fitted"]["base_compliance"] > 0.0
    assert 0.05e-3 < doc["fitted"]["drive_backlash"] < 0.2e-3  # measured 0.102 mm


def test_tension_data_through_the_drive_model_equal_the_analytic_backend():
    """The drive model's tension path (fit names of the base frame on tension data) predicts
    what AnalyticBackend.equilibrium does."""
    from cdcr_gym.calibration.simulate import AnalyticReplay

    p = RobotParams.preset("tdcr2")
    t = np.random.default_rng(3).uniform(0.0, 3.0, (20, p.n_cables))
    data = Measurements(t, np.zeros((20, 3)), None, None)
    a = AnalyticReplay(data, p)({})
    b = DriveReplay(data, p)({})
    np.testing.assert_allclose(b.tip, a.tip, atol=1e-12)
    np.testing.assert_allclose(b.tip_direction, a.tip_direction, atol=1e-12)
    shifted = DriveReplay(data, p)({"base_z": 0.01})
    np.testing.assert_allclose(shifted.tip - b.tip, np.tile([0.0, 0.0, 0.01], (20, 1)), atol=1e-12)
