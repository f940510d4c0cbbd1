"""cdcr_gym.calibration and ``cdcr-gym calibrate``: the CSV format, the fit on the analytic model
and on a physics backend, the errors, the YAML the envs read."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.calibration import Measurements, calibrate, load_fitted, read_csv, write_csv
from cdcr_gym.calibration.simulate import AnalyticReplay, BackendReplay
from cdcr_gym.model.params import STANDARD_GRAVITY
from cdcr_gym.params import RobotParams
from training.studies import calibrate as cli

HEADER = "T1,T2,T3,direction,x,y,z,sigma\n"


def _sweep_tensions() -> np.ndarray:
    """Each cable in turn 0 → 80 N (25 rows)."""
    loads = np.linspace(10.0, 80.0, 8)
    rows = [np.zeros(3)]
    for c in range(3):
        for t in loads:
            row = np.zeros(3)
            row[c] = t
            rows.append(row)
    return np.array(rows)


def _analytic_data(truth: dict, sigma: float, seed: int = 0) -> Measurements:
    tensions = _sweep_tensions()
    template = Measurements(tensions, np.zeros((len(tensions), 3)), None, None)
    tip = AnalyticReplay(template, RobotParams())(truth).tip
    noisy = tip + np.random.default_rng(seed).normal(0.0, sigma, tip.shape)
    return Measurements(tensions, noisy, None, np.full(len(tensions), sigma))


# -- the fit ---------------------------------------------------------------------------------------


def test_analytic_round_trip_recovers_the_parameters():
    truth = {
        "youngs_modulus": 28e9,
        "cable_angle_2": math.radians(2.0),
        "base_tilt_x": math.radians(0.5),
        "base_tilt_y": math.radians(-0.3),
    }
    data = _analytic_data(truth, sigma=2e-5)
    res = calibrate(data, RobotParams(), "E,cable_angle_2,tilt")
    assert res.success and res.identifiable
    assert res.values["youngs_modulus"] == pytest.approx(28e9, rel=1e-3)
    for name in ("cable_angle_2", "base_tilt_x", "base_tilt_y"):
        assert res.values[name] == pytest.approx(truth[name], abs=math.radians(0.02))
        # the truth lies inside the 95 % interval (here a few sigma)
        assert abs(res.values[name] - truth[name]) < 3 * res.ci95[name]
    assert np.median(res.errors_before) > 0.02  # tens of mm before
    assert np.median(res.errors_after) < 5e-5
    assert res.params.youngs_modulus == res.values["youngs_modulus"]
    assert res.params.cable_angles[1] == pytest.approx(
        2 * math.pi / 3 + res.values["cable_angle_2"]
    )


def test_tip_tangents_are_fitted_too(tmp_path):
    tensions = _sweep_tensions()
    template = Measurements(tensions, np.zeros((len(tensions), 3)), None, None)
    pred = AnalyticReplay(template, RobotParams())({"youngs_modulus": 30e9})
    data = Measurements(tensions, pred.tip, None, 1e-3, pred.tip_direction, 1e-3)
    write_csv(tmp_path / "t.csv", data)
    again = read_csv(tmp_path / "t.csv")
    assert again.tip_direction is not None
    res = calibrate(again, RobotParams(), "E", start={"youngs_modulus": 40e9})
    assert res.values["youngs_modulus"] == pytest.approx(30e9, rel=1e-6)
    with pytest.raises(ValueError, match=r"start values given for \['tip_payload'\]"):
        calibrate(again, RobotParams(), "E", start={"tip_payload": 0.01})


def test_stiffness_and_radius_are_not_identifiable_from_tips_alone():
    data = _analytic_data({"youngs_modulus": 30e9}, sigma=1e-5)
    res = calibrate(data, RobotParams(), "E,r")
    assert not res.identifiable
    assert math.isinf(res.ci95["youngs_modulus"])
    assert any("singular" in n for n in res.notes)
    # the tips are still fitted: the pure-moment statics depend on r/E only
    assert np.median(res.errors_after) < 1e-4


@pytest.mark.parametrize("backend", ["bullet", "mujoco"])
def test_physics_backend_fit_on_a_few_points(backend):
    """Smoke test: 5 rows loaded up and down on cable 1, E and μ recovered on a physics
    backend replayed in order."""
    tensions = np.array([[0.0, 0, 0], [40, 0, 0], [78, 0, 0], [40, 0, 0], [0, 0, 0]])
    template = Measurements(tensions, np.zeros((5, 3)), [1, 1, 1, -1, -1], None)
    kw = {"gravity": True, "friction_slip_length": 2e-3}
    truth = {"youngs_modulus": 30e9, "friction_coefficient": 0.15}
    tip = BackendReplay(template, RobotParams(), backend, kw, 5, 25)(truth).tip
    data = Measurements(tensions, tip, template.direction, np.full(5, 2e-5))
    res = calibrate(
        data, RobotParams(), "E,mu", backend, kw, ramp_steps=5, settle_steps=25, max_nfev=12
    )
    assert res.values["youngs_modulus"] == pytest.approx(30e9, rel=0.02)
    assert res.values["friction_coefficient"] == pytest.approx(0.15, abs=0.03)
    assert res.backend_kwargs["friction_coefficient"] == res.values["friction_coefficient"]
    assert np.median(res.errors_after) < 5e-4 < np.median(res.errors_before)


# -- errors ----------------------------------------------------------------------------------------


def test_unknown_parameter_names_are_named():
    data = _analytic_data({}, 1e-5)
    with pytest.raises(
        ValueError, match=r"unknown parameter 'youngs'.*did you mean 'youngs_modulus'"
    ):
        calibrate(data, RobotParams(), "youngs")
    with pytest.raises(ValueError, match="'stiffness'"):
        calibrate(data, RobotParams(), ["E", "stiffness"])
    with pytest.raises(ValueError, match="friction_coefficient.*analytic"):
        calibrate(data, RobotParams(), "E,mu")
    with pytest.raises(ValueError, match="given twice"):
        calibrate(data, RobotParams(), "E,youngs_modulus")


def test_too_few_points_for_the_parameters():
    data = _analytic_data({}, 1e-5).subset(slice(0, 3))
    with pytest.raises(ValueError, match=r"too few points: 3 measurement\(s\) for 4 parameter"):
        calibrate(data, RobotParams(), "E,cable_angle_2,tilt")


def test_cable_count_mismatch_is_an_error():
    data = _analytic_data({}, 1e-5)
    with pytest.raises(ValueError, match="3 cable column.*6 cables"):
        calibrate(data, RobotParams.preset("tdcr2"), "E")


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "data.csv"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            HEADER + "0,0,0,up,0,0,0.641,2e-5\n10,0,0,up,0.06,0,abc,2e-5\n",
            r"data.csv line 3, column 'z': 'abc' is not a number",
        ),
        (
            "# comment\n\n" + HEADER + "0,0,0,up,0,0,0.641,2e-5\n-1,0,0,up,0,0,0.6,2e-5\n",
            r"data.csv line 5, column 'T1': a cable cannot push",
        ),
        (HEADER + "0,0,0,sideways,0,0,0.641,2e-5\n", r"line 2, column 'direction'.*'sideways'"),
        (
            HEADER + "10,0,0,up,0,0,0.641,2e-5\n5,0,0,up,0,0,0.6,2e-5\n",
            r"line 3, column 'direction': 'up', but the total tension fell",
        ),
        (HEADER + "0,0,0,up,0,0,0.641\n", r"line 2: 7 values for 8 columns"),
        (HEADER + "0,0,0,up,0,0,0.641,0\n", r"line 2, column 'sigma': must be > 0"),
        ("T1,T2,T3,x,y\n0,0,0,0,0\n", r"line 1 \(header\): missing column 'z'"),
        ("T1,T2,T3,x,y,z,temp\n0,0,0,0,0,0,1\n", r"unknown column\(s\) \['temp'\]"),
        ("T1,m2,T3,x,y,z\n0,0,0,0,0,0\n", r"either tensions .* or masses"),
        ("T1,T3,x,y,z\n0,0,0,0,0\n", r"missing \['T2'\]"),
        ("x,y,z\n0,0,0\n", r"no cable columns"),
        (HEADER, r"a header but no data rows"),
    ],
)
def test_malformed_csv_names_line_and_column(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        read_csv(_write(tmp_path, text))


def test_csv_masses_and_round_trip(tmp_path):
    path = _write(
        tmp_path,
        "# the paper's protocol: hanging masses on cable 1\n"
        "m1,m2,m3,direction,x,y,z,label\n"
        "0,0,0,,0,0,0.641,start\n"
        "0.5,0,0,up,0.04,0,0.64,\n"
        "0,0,0,down,0,0,0.641,end\n",
    )
    data = read_csv(path)
    assert data.from_masses and data.lines.tolist() == [3, 4, 5]
    assert data.tensions[1, 0] == pytest.approx(0.5 * STANDARD_GRAVITY)
    assert data.direction.tolist() == [0, 1, -1] and data.labels[0] == "start"
    write_csv(tmp_path / "again.csv", data, "written back")
    again = read_csv(tmp_path / "again.csv")
    np.testing.assert_array_equal(again.tensions, data.tensions)
    np.testing.assert_array_equal(again.tip, data.tip)
    np.testing.assert_array_equal(again.direction, data.direction)


# -- YAML and the envs -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "params",
    [
        RobotParams(),
        RobotParams.preset("tdcr2"),
        RobotParams(youngs_modulus=2.8123456789e10, cable_radius=0.0295 + 1e-17, disk_mass=1.5e-5),
    ],
)
def test_yaml_round_trip_is_exact(params):
    assert RobotParams.from_yaml(params.to_yaml()) == params


def test_yaml_errors_name_the_key(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("youngs_modulus: 3.0e10\nstiffnes: 1.0\n")
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['stiffnes'\]"):
        RobotParams.from_yaml(path)
    path.write_text("preset: paper\nyoungs_modulus: 3.0e10\n")
    assert RobotParams.from_yaml(path) == RobotParams(youngs_modulus=3e10)


def test_fitted_yaml_is_accepted_by_the_envs(tmp_path):
    data = _analytic_data({"youngs_modulus": 30e9}, sigma=2e-5)
    out = tmp_path / "out"
    csv_path = tmp_path / "d.csv"
    write_csv(csv_path, data)
    assert cli.main([str(csv_path), "--fit", "E", "--out", str(out), "--quiet"]) == 0
    for name in ("params.yaml", "report.md", "residuals.png"):
        assert (out / name).is_file()
    assert "± 95 % CI" in (out / "report.md").read_text()
    fitted = RobotParams.from_yaml(out / "params.yaml")
    assert fitted.youngs_modulus == pytest.approx(30e9, rel=1e-3)
    params, backend_kwargs = load_fitted(out / "params.yaml")
    assert params == fitted and backend_kwargs == {}
    env = gym.make("cdcr_gym/CCKAReach-v0", params=str(out / "params.yaml"))
    try:
        assert env.unwrapped.backend.params == fitted
        env.reset(seed=0)
    finally:
        env.close()


def test_cli_errors_exit_2_naming_the_problem(tmp_path, capsys):
    data = _analytic_data({}, 1e-5)
    csv_path = tmp_path / "d.csv"
    write_csv(csv_path, data)
    with pytest.raises(SystemExit) as exc:
        cli.main([str(csv_path), "--fit", "E,bogus", "--out", str(tmp_path / "o")])
    assert exc.value.code == 2 and "'bogus'" in capsys.readouterr().err
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(SystemExit):
        cli.main([str(csv_path), "--out", str(blocker / "sub")])
    assert "--out" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main([str(csv_path), "--fit", "mu", "--out", str(tmp_path / "o")])
    assert "analytic" in capsys.readouterr().err
