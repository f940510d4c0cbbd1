"""Tests of ``python -m training.studies.reproduce``: the physics of the study, not just its files.

Most tests drive the pipeline with stand-in backends (the analytic CCKA backend, a backend that
never settles); one test runs the study on a coarse grid on the pybullet backbone and
checks what the paper's study should show: zero force ⇒ straight robot, gravity-off CCKA error
below 1 % of ℓ, error growing with the tip payload (a few seconds: the backend's reset gives the
static equilibrium directly).
"""

from __future__ import annotations

import csv
import math
import os

import numpy as np
import pytest

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.model.params import RobotParams
from training.studies import reproduce as R
from training.studies.reproduce.report import cantilever_sag, crossing

P = RobotParams()
ELL = P.length


# ---------------------------------------------------------------------------------------------
# Stand-in backends
# ---------------------------------------------------------------------------------------------
class _Analytic(AnalyticBackend):
    """The CCKA backend behind the study's factory signature (ignores gravity and payload)."""

    def __init__(self, params, *, gravity, links_per_span, tip_payload, base_orientation):
        super().__init__(params, num_robots=1)


def analytic_factory(params, **kwargs):
    return _Analytic(params, **kwargs)


class _Drifting(Backend):
    """One robot (N = 1) whose tip creeps forever (or turns NaN): settle() must refuse it.

    Checks that every command comes as a batch of one robot, shape (1, C).
    """

    def __init__(self, params=P, *, nan=False, **_):
        self.params = params
        self.nan = nan
        self._tip = np.array([0.0, 0.0, ELL])
        self._tensions = np.zeros((1, params.n_cables))

    def _command(self, tensions):
        tensions = np.asarray(tensions, dtype=np.float64)
        assert tensions.shape == (1, self.n_cables), tensions.shape
        self._tensions = tensions.copy()

    def reset(self, tensions, mask=None):
        self._command(tensions)
        self._tip = np.array([0.0, 0.0, ELL])

    def apply_tensions(self, tensions):
        self._command(tensions)
        self._tip = self._tip + (np.nan if self.nan else 1e-5)

    def read(self):
        return Readings(
            self._tip[None].copy(),
            np.array([[0.0, 0.0, 1.0]]),
            np.full((1, self.n_cables), ELL),
            self._tensions.copy(),
        )

    def equilibrium(self, tensions):
        m = np.asarray(tensions).shape[0]
        return Readings(
            np.tile([0.0, 0.0, ELL], (m, 1)),
            np.tile([0.0, 0.0, 1.0], (m, 1)),
            np.full((m, self.n_cables), ELL),
            np.asarray(tensions, float),
        )

    def backbone_points(self, index=0):
        return np.stack([np.zeros(3), self._tip])

    def disk_frames(self, index=0):
        return np.stack([np.zeros(3), self._tip]), np.stack([np.eye(3)] * 2)


class _Converging(_Drifting):
    """Tip relaxes geometrically towards a point: settles after a predictable number of steps."""

    def apply_tensions(self, tensions):
        self._command(tensions)
        self._tip = self._tip + 0.5 * (np.array([0.01, 0.0, ELL]) - self._tip)


class _ResetRefuses(_Converging):
    """reset() refuses any non-zero tension (like an equilibrium solver that does not converge)."""

    def reset(self, tensions, mask=None):
        if np.any(np.asarray(tensions) != 0.0):
            raise RuntimeError("equilibrium solver did not converge")
        super().reset(tensions, mask)


class _AlwaysRefuses(_Converging):
    def reset(self, tensions, mask=None):
        raise RuntimeError("nope")


# ---------------------------------------------------------------------------------------------
# Fast tests
# ---------------------------------------------------------------------------------------------
def test_ccka_sweep_is_the_papers_fig6():
    c = R.ccka_cable_sweep(P, dl_max=0.04, n=21)
    # Δl = 0 gives the straight robot exactly; the backbone length is preserved.
    np.testing.assert_allclose(c.tip[0], [0.0, 0.0, ELL], atol=1e-15)
    np.testing.assert_allclose(c.lengths.sum(axis=1), 3 * ELL, rtol=1e-14)
    # l1 = ℓ − Δl, l2 = l3 = ℓ + Δl/2 gives θ = Δl/r in the plane of cable 1 (φ = 0: +X, Y = 0).
    np.testing.assert_allclose(c.theta, c.dl / P.cable_radius, rtol=1e-12)
    assert np.all(np.abs(c.tip[:, 1]) < 1e-12)
    assert np.all(np.diff(c.tip[:, 0]) > 0) and np.all(np.diff(c.tip[:, 2]) < 0)
    # the shapes end at the tips and start at the base
    np.testing.assert_allclose(c.shapes[:, 0], 0.0, atol=1e-15)
    np.testing.assert_allclose(c.shapes[-1, -1], R.ccka_cable_sweep(P, 0.04, 2).tip[-1], atol=1e-12)


def test_default_dl_range_matches_the_force_range():
    # r·θ(80 N) of the pure-moment model: the CCKA sweep spans the bends the force sweep produces.
    cfg = R.StudyConfig()
    assert cfg.resolved_dl_max == pytest.approx(P.cable_radius * P.max_bending_angle, rel=1e-12)


def test_settle_refuses_a_robot_that_never_settles():
    with pytest.raises(R.SettleError, match=r"no static equilibrium.*tolerance"):
        R.settle(_Drifting(), np.array([40.0, 0, 0]), tol=1e-6, window=5, max_steps=50)
    with pytest.raises(R.SettleError, match="non-finite"):
        R.settle(_Drifting(nan=True), np.zeros(3), window=5, max_steps=50)


def test_settle_reports_steps_motion_and_drift():
    info = R.settle(_Converging(), np.zeros(3), tol=1e-6, window=5, max_steps=1000)
    assert info.motion <= 1e-6
    assert info.steps % 5 == 0 and 5 <= info.steps < 100
    assert info.drift == pytest.approx(0.01, rel=1e-3)  # it had to move from the start


def test_settle_falls_back_to_the_dynamic_route():
    info = R.settle(
        _ResetRefuses(), np.array([40.0, 0, 0]), tol=1e-6, window=5, max_steps=1000, ramp_steps=10
    )
    assert info.route == "dynamic" and info.motion <= 1e-6 and info.steps > 10
    assert math.isnan(info.drift)
    with pytest.raises(R.SettleError, match="dynamic route"):
        R.settle(_AlwaysRefuses(), np.array([40.0, 0, 0]))


def test_preflight_stops_a_configuration_the_backend_refuses(tmp_path, capsys):
    def picky(params, *, links_per_span, **kwargs):
        if links_per_span > 2:
            raise ValueError(f"too many links: {links_per_span}")
        return analytic_factory(params, links_per_span=links_per_span, **kwargs)

    code = R.main(
        ["--out", str(tmp_path / "o"), "--quick", "--links-per-span", "2", "--resolution", "1,3"],
        factory=picky,
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "9 disks × 3 links per span" in err and "too many links" in err
    assert not (tmp_path / "o").exists()  # stopped before any sweep or output


def test_settle_error_names_the_sweep():
    with pytest.raises(R.SettleError, match=r"\[my sweep\]"):
        R.run_force_sweep(
            lambda params, **kw: _Drifting(params),
            P,
            [0.0, 10.0],
            label="my sweep",
            gravity=False,
            settle_window=5,
            settle_max_steps=20,
        )


def test_crossing_interpolates_and_reports_none():
    x = np.array([0.0, 1.0, 2.0])
    assert crossing(x, np.array([0.0, 1.0, 3.0]), 2.0) == pytest.approx(1.5)
    assert crossing(x, np.array([5.0, 6.0, 7.0]), 2.0) == 0.0
    assert crossing(x, np.array([0.0, 0.1, 0.2]), 2.0) is None


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--forces", "1"], "--forces"),
        (["--forces", "x"], "--forces"),
        (["--max-force", "120"], "--max-force"),
        (["--max-force", "-3"], "--max-force"),
        (["--payloads-g", "0,-5"], "--payloads-g"),
        (["--payloads-g", "100,50"], "--payloads-g"),
        (["--payloads-g", "a,b"], "--payloads-g"),
        (["--disks", "0,9"], "--disks"),
        (["--settle-tol", "0"], "--settle-tol"),
        (["--report-copy", "notes.txt"], "--report-copy"),
    ],
)
def test_cli_rejects_bad_arguments(argv, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        R.main(["--out", str(tmp_path / "out"), *argv], factory=analytic_factory)
    assert exc.value.code != 0
    assert message in capsys.readouterr().err


def test_cli_rejects_an_out_that_is_a_file(tmp_path, capsys):
    f = tmp_path / "a_file"
    f.write_text("x")
    for out in (f, f / "sub"):
        with pytest.raises(SystemExit) as exc:
            R.main(["--out", str(out)], factory=analytic_factory)
        assert exc.value.code != 0
        assert "--out" in capsys.readouterr().err


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs /proc (Linux)")
def test_an_unwritable_out_is_refused_before_the_study_runs(capsys):
    """Issue 23.4: ``--out /proc/x`` once ran the whole study, then failed and saved nothing
    (``os.access`` says yes to root on /proc); the location is now probed first."""

    def must_not_run(*args, **kwargs):
        raise AssertionError("the study ran before the output location was checked")

    with pytest.raises(SystemExit) as exc:
        R.main(["--out", "/proc/x", "--quick"], factory=must_not_run)
    assert exc.value.code == 2
    assert "--out '/proc/x'" in capsys.readouterr().err


def test_pipeline_end_to_end_on_the_analytic_backend(tmp_path):
    """CCKA against itself: zero error everywhere, and every output is complete and consistent."""
    out = tmp_path / "rep"
    copy = tmp_path / "docs" / "reproduce.md"
    code = R.main(
        ["--out", str(out), "--quick", "--report-copy", str(copy)], factory=analytic_factory
    )
    assert code == 0
    for name in (
        "summary.csv",
        "ccka_cable_sweep.csv",
        "sim_gravity_off.csv",
        "sim_gravity_on.csv",
        "payload.csv",
        "resolution.csv",
        "horizontal_base.csv",
        "report.md",
        "run.json",
        "fig05_sim_tip_vs_force.png",
        "fig06_ccka_cable_sweep.png",
        "fig07_ccka_shapes.png",
        "fig10_sim_vs_ccka.png",
        "fig11_error_gravity_off.png",
        "fig12_error_gravity_on.png",
        "fig_payload_error.png",
        "fig_shapes_vs_arc.png",
        "fig_resolution.png",
    ):
        assert (out / name).stat().st_size > 0, name
    assert (out / "fig05_sim_tip_vs_force.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with (out / "sim_gravity_off.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 5
    assert max(float(r["err_norm_m"]) for r in rows) < 1e-12
    # the analytic backend *is* CCKA: the tip is the elastica's
    last = rows[-1]
    assert math.hypot(float(last["tip_sim_x_m"]), float(last["tip_sim_y_m"])) > 0.3  # m, bent
    report = (out / "report.md").read_text()
    for needed in (
        "4.95",
        "0.77",
        "2.4",
        "0.37",
        "Where CCKA stops holding",
        "| case |",
        "fig11_error_gravity_off.png",
        "cdcr-gym reproduce",
    ):
        assert needed in report, needed
    assert "nan" not in report.lower().replace("nonlinear", "")
    # the copy links to the figures relative to its own folder
    text = copy.read_text()
    assert "](../rep/fig05_sim_tip_vs_force.png)" in text


def test_settle_reads_the_analytic_backend_at_its_equilibrium():
    # the quasi-static backend jumps to equilibrium: settled at the first window, no drift
    b = _Analytic(
        P, gravity=False, links_per_span=1, tip_payload=0.0, base_orientation=(0.0, 0.0, 0.0, 1.0)
    )
    t = R.cable1_tensions(40.0, P)
    info = R.settle(b, t, window=5)
    assert info.route == "reset" and info.steps == 5 and info.motion == 0.0 and info.drift == 0.0
    np.testing.assert_array_equal(R.tip_of(b), b.equilibrium(t[None]).tip[0])


def test_cable1_tensions():
    np.testing.assert_array_equal(R.cable1_tensions([0.0, 5.0], P), [[0.0, 0, 0], [5.0, 0, 0]])
    assert R.cable1_tensions(80.0, P).shape == (P.n_cables,)


def test_config_validation():
    with pytest.raises(ValueError, match="forces"):
        R.StudyConfig(forces=(0.0, 90.0))
    with pytest.raises(ValueError, match="forces"):
        R.StudyConfig(forces=(40.0, 0.0))
    with pytest.raises(ValueError, match="payloads"):
        R.StudyConfig(payloads=(0.0, -0.1))
    with pytest.raises(ValueError, match="n_disks_values"):
        R.StudyConfig(n_disks_values=(0,))
    with pytest.raises(ValueError, match="one section driven by three cables"):
        R.StudyConfig(params=RobotParams.preset("tdcr2"))


def test_the_package_keeps_its_entry_points():
    from training.studies.reproduce import __main__, cli, plots, report, study

    assert R.main is cli.main and R.settle is study.settle
    assert callable(plots.make_figures) and callable(report.render)
    assert __main__.main is cli.main


# ---------------------------------------------------------------------------------------------
# The study on the pybullet backbone (coarse grid)
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def study():
    cfg = R.quick_config(
        forces=(0.0, 20.0, 40.0, 60.0, 80.0),
        payloads=(0.0, 0.1, 0.2),
        n_disks_values=(9,),
        links_per_span_values=(1,),
        resolution_forces=(0.0, 80.0),
        horizontal=True,
    )
    return R.run_study(cfg, log=lambda s: None)


def test_study_physics_on_the_bullet_backbone(study, tmp_path):
    off, on = study.gravity_off, study.gravity_on
    straight = np.array([0.0, 0.0, ELL])

    # Zero force ⇒ the straight robot (upright, gravity off and on: the joints cannot extend),
    # all cables of length ℓ, and CCKA agrees.
    for s in (off, on):
        assert s.forces[0] == 0.0
        np.testing.assert_allclose(s.tip_sim[0], straight, atol=1e-4)
        np.testing.assert_allclose(s.lengths[0], ELL, atol=1e-4)
        assert s.error_norm[0] < 1e-4

    # Pulling cable 1 bends towards +X0 in the X–Z plane, more with more force.
    assert np.all(np.diff(off.tip_sim[:, 0]) > 0) and np.all(np.diff(off.tip_sim[:, 2]) < 0)
    assert np.all(np.abs(off.tip_sim[:, 1]) < 1e-4)
    # ... by about the elastica's angle (θ = T·r·ℓ/EI ≈ 79° at 80 N); the 9-disk robot a little
    # more (the cable is straight between disks).
    theta_el = P.max_bending_angle
    assert 1.0 <= off.theta_sim[-1] / theta_el < 1.08

    # Gravity off (the paper's simulation): CCKA from the sensed lengths within 1 % of ℓ.
    assert off.error_norm.max() < 0.01 * ELL

    # Gravity on (upright): the weight bends the bent robot unevenly; CCKA errs more than off.
    assert on.error_norm.max() > 2.0 * off.error_norm.max()

    # A tip payload makes the shape stop being an arc: the error grows with the payload.
    means = [s.error_norm.mean() for s in study.payload]
    assert [s.payload for s in study.payload] == [0.0, 0.1, 0.2]
    assert np.all(np.diff(means) > 0), means
    assert study.payload[-1].error_norm.max() > off.error_norm.max()

    # A horizontal base: the cantilever sags under its weight at zero tension; CCKA misses it.
    h = study.horizontal
    assert h.error_norm[0] > 0.01 * ELL
    sag = np.linalg.norm(h.tip_sim[0] - straight)
    assert sag == pytest.approx(cantilever_sag(P), rel=0.1)  # Euler–Bernoulli, small deflection

    # Every state was a verified equilibrium.
    for s in (off, on, *study.payload, h):
        assert np.all(s.settle_motion <= study.config.settle_tol)

    # The outputs of this run: the table rows and the finding paragraph come from these numbers.
    paths = R.write_outputs(study, tmp_path, dpi=50, command="pytest")
    with paths["summary_csv"].open() as fh:
        rows = {r["case"]: r for r in csv.DictReader(fh)}
    gravity_off_row = next(
        r for k, r in rows.items() if k.startswith("CCKA vs simulation, gravity off")
    )
    assert float(gravity_off_row["mean_mm"]) == pytest.approx(1e3 * off.error_norm.mean(), rel=1e-6)
    report = paths["report"].read_text()
    assert f"{1e3 * off.error_norm.max():.2f} mm" in report
