"""damping_ratio as a physical quantity: the stepped-mode model, the backends' delivered ζ
(committed table and one live release per backend), the refusals, and the step-response fit
behind ``cdcr-gym calibrate --damping-step``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cdcr_gym.backends.damping import damping_time, minimum_damping_ratio, stepped_mode
from cdcr_gym.calibration.damping import (
    StepResponse,
    fit_second_order,
    fit_step_response,
    read_step_csv,
    write_step_csv,
)

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "experiments" / "dynamics" / "damping.json"
DEMO = ROOT / "docs" / "figures" / "calibration" / "damping" / "fit.json"
W1 = 2.0 * math.pi * 3.0  # rad/s, about the paper robot's first mode


# -- the stepped mode -----------------------------------------------------------------------
def test_stepped_mode_limits():
    """Exact: ζ = d/(2ω). Symplectic Euler without damping: no decay. Backward Euler without
    damping: ζ ≈ h·ω/2 for small h·ω."""
    w, z = stepped_mode(W1**2, 2 * 0.3 * W1, 0.01, "exact")
    assert w == pytest.approx(W1) and z == pytest.approx(0.3)
    assert stepped_mode(W1**2, 0.0, 0.02, "symplectic")[1] == pytest.approx(0.0, abs=1e-9)
    h = 1e-3
    assert stepped_mode(W1**2, 0.0, h, "backward")[1] == pytest.approx(h * W1 / 2, rel=1e-2)
    # a step beyond symplectic Euler's limit h·ω < 2 without damping diverges
    assert stepped_mode(W1**2, 0.0, 3.0 / W1, "symplectic")[1] == math.inf


@pytest.mark.parametrize("scheme,h", [("symplectic", 0.02), ("backward", 0.01), ("exact", 0.01)])
@pytest.mark.parametrize("zeta", [0.3, 0.7, 1.0, 1.3])
def test_damping_time_inverts_the_stepped_mode(scheme, h, zeta):
    w2, kappa = (0.93 * W1) ** 2, W1**2  # with gravity: ω₁g < ω₁
    beta = damping_time(zeta, w2, kappa, h, scheme)
    assert stepped_mode(w2, beta * kappa, h, scheme, kappa)[1] == pytest.approx(zeta, rel=1e-8)


def test_damping_time_refuses_below_the_minimum():
    low = minimum_damping_ratio(W1**2, W1**2, 0.01, "backward")
    assert 0.08 < low < 0.1
    with pytest.raises(ValueError, match=r"damping_ratio=0\.05 .*0\.09"):
        damping_time(0.05, W1**2, W1**2, 0.01, "backward")


# -- the backends ---------------------------------------------------------------------------
def test_committed_table_delivers_the_stated_ratio():
    """``python -m experiments.damping_check``: every accepted ζ within 10 % (in fact 3.3 %),
    gravity off and on, both backends at their default timesteps; bullet takes ζ >= 0.1,
    MuJoCo refuses only below its stable minimum (0.24 at 20 ms)."""
    rows = json.loads(TABLE.read_text())["rows"]
    assert {r["backend"] for r in rows} == {"mujoco", "bullet"}
    assert {r["gravity"] for r in rows} == {False, True}
    for r in rows:
        if "refused" in r:
            assert r["backend"] == "mujoco" and r["damping_ratio_set"] < 0.25, r
            assert "physics_timestep <=" in r["refused"]
            continue
        err = abs(r["damping_ratio_measured"] - r["damping_ratio_set"]) / r["damping_ratio_set"]
        assert err < 0.10, r
    accepted = {(r["backend"], r["damping_ratio_set"]) for r in rows if "refused" not in r}
    assert {("bullet", z) for z in (0.1, 0.2, 0.3, 0.5, 0.7, 1.0)} <= accepted
    assert {("mujoco", z) for z in (0.3, 0.5, 0.7, 1.0)} <= accepted


@pytest.mark.parametrize("backend", ["mujoco", "bullet"])
def test_live_release_delivers_the_stated_ratio(backend):
    """A short live release (1 s, gravity on) at ζ = 0.4: within 10 %."""
    from experiments.damping_check import FIT_START, release

    t, x = release(backend, "paper", 0.4, True, duration=1.0)
    keep = t >= FIT_START
    _, zeta, _ = fit_second_order(t[keep], x[keep])
    assert zeta == pytest.approx(0.4, rel=0.10)


def test_mujoco_refuses_a_ratio_its_step_cannot_deliver():
    from cdcr_gym.backends.mujoco import MuJoCoBackend

    with pytest.raises(
        ValueError, match=r"damping_ratio=0\.1 .*0\.2\d.*physics_timestep <= 0\.005"
    ):
        MuJoCoBackend(damping_ratio=0.1)
    b = MuJoCoBackend(damping_ratio=0.1, physics_timestep=0.005)  # the suggested step
    assert b.damping_time > 0.0
    b.close()


def test_bullet_refuses_a_ratio_below_its_numerical_damping():
    from cdcr_gym.backends.bullet import BulletBackend

    with pytest.raises(ValueError, match=r"damping_ratio=0\.05 .*physics_timestep <= 0\.005"):
        BulletBackend(damping_ratio=0.05)


# -- the step-response fit ------------------------------------------------------------------
def _second_order(zeta: float, w: float, t: np.ndarray) -> np.ndarray:
    wd = w * math.sqrt(1 - zeta**2)
    return np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))


@pytest.mark.parametrize("zeta", [0.1, 0.4, 0.8])
def test_fit_recovers_a_noisy_second_order_step(tmp_path, zeta):
    rng = np.random.default_rng(1)
    t = np.arange(-0.1, 3.0, 0.01)
    s = np.where(t < 0, 1.0, _second_order(zeta, W1, np.maximum(t, 0.0))) * 0.02
    axis = np.array([0.6, 0.8, 0.0])
    tips = np.array([0.0, 0.0, 0.6]) + s[:, None] * axis + rng.normal(0, 1e-4, (t.size, 3))
    path = tmp_path / "step.csv"
    write_step_csv(path, StepResponse(t, tips), "synthetic")
    fit = fit_step_response(path)
    assert fit.damping_ratio == pytest.approx(zeta, rel=0.05)
    assert fit.frequency_hz == pytest.approx(W1 / (2 * math.pi), rel=0.02)
    assert abs(np.dot(fit.axis, axis)) == pytest.approx(1.0, abs=1e-3)


def test_committed_demo_recovers_the_known_ratio_within_5_percent():
    rows = json.loads(DEMO.read_text())["rows"]
    assert {r["backend"] for r in rows} == {"mujoco", "bullet"}
    for r in rows:
        assert abs(r["error_pct"]) < 5.0, r
        fit = fit_step_response(DEMO.parent / r["file"])  # the committed CSV refits the same
        assert fit.damping_ratio == pytest.approx(r["damping_ratio_fit"], rel=1e-6)


def test_demo_on_a_live_backend():
    """The demo's generator (MuJoCo, ζ = 0.5, 0.1 mm noise) fitted back within 5 %."""
    from experiments.damping_demo import synthetic_step

    fit = fit_step_response(synthetic_step("mujoco", 0.5, duration=1.5))
    assert fit.damping_ratio == pytest.approx(0.5, rel=0.05)


def _write(tmp_path, text: str) -> Path:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return path


GOOD_ROWS = "".join(f"{0.01 * i},0,0,{0.6 + 1e-3 * math.cos(i)}\n" for i in range(12))


@pytest.mark.parametrize(
    "text,match",
    [
        ("t,x,y\n" + GOOD_ROWS, r"bad\.csv line 1 \(header\): missing column 'z'"),
        (
            "t,x,y,z\n0,0,0,0.6\n0.01,0,abc,0.6\n",
            r"bad\.csv line 3, column 'y': 'abc' is not a number",
        ),
        (
            "# c\nt,x,y,z\n0,0,0,0.6\n0.01,0,0,nan\n",
            r"bad\.csv line 4, column 'z': 'nan' is not finite",
        ),
        ("t,x,y,z\n0,0,0,0.6\n0,0,0,0.6\n", r"bad\.csv line 3, column 't': times must increase"),
        ("t,x,y,z\n0,0,0\n", r"bad\.csv line 2: 3 values for 4 columns"),
        ("t,x,y,z\n0,0,0,0.6\n", r"bad\.csv: 1 rows at t >= 0, need >= 10"),
        ("", r"bad\.csv: no header and no data rows"),
    ],
)
def test_malformed_step_files_name_file_line_column(tmp_path, text, match):
    with pytest.raises(ValueError, match=match):
        read_step_csv(_write(tmp_path, text))


def test_missing_step_file(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        read_step_csv(tmp_path / "none.csv")


def test_calibrate_cli_damping_step(tmp_path, capsys):
    from training.studies.calibrate import main

    csv = DEMO.parent / "step_mujoco_0.3.csv"
    assert main(["--damping-step", str(csv), "--out", str(tmp_path)]) == 0
    assert "damping_ratio=0.298" in capsys.readouterr().out
    record = json.loads((tmp_path / "damping.json").read_text())
    assert record["damping_ratio"] == pytest.approx(0.3, rel=0.05)
    with pytest.raises(SystemExit):
        main(["--damping-step", str(tmp_path / "missing.csv")])
