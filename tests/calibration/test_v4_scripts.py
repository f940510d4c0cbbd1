"""Smoke tests of the FTDCR v4 study scripts under configs/calibration/ (their helpers on a few
rows; the committed outputs come from the full runs)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from cdcr_gym.calibration import read_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.model.params import RobotParams

ROOT = Path(__file__).resolve().parents[2]
V4 = RobotParams.preset("ftdcr_v4")


def _module(name: str, folder: str = "configs/calibration"):
    spec = importlib.util.spec_from_file_location(name, ROOT / folder / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_pattern_families_of_the_v4_labels():
    sel = _module("ftdcr_v4_ccka_selection")
    assert sel.family("rep1_pair12_same_dir60_hold") == "pair12_same"
    assert sel.family("rep1_all3_scurve_dir0") == "scurve"
    assert sel.family("rep1_tendon4_id2_pull") == "tendon4"
    assert sel.family("rep1_seg2_circle") == "seg2_circle"
    val = read_csv(ROOT / "data/real/ftdcr_v4/val.csv", robot=V4, drive=TendonDrive.of(V4))
    fams = {sel.family(lab) for lab in val.labels}
    assert fams == {"same", "scurve", "spiral"}
    # per family: the aligned errors of a constant offset are zero, of a shift in one family not
    pred = val.tip + 0.003
    out = sel.per_family(pred, val, V4.length)
    assert all(r["rmse_aligned_mm"] < 1e-9 for r in out.values())
    assert sum(r["rows"] for r in out.values()) == len(val)
    pred = val.tip.copy()
    m = np.array([sel.family(lab) == "same" for lab in val.labels])
    pred[m, 0] += 0.002
    out = sel.per_family(pred, val, V4.length)
    assert out["same"]["rmse_aligned_xyz_mm"][0] > 1.0 > out["spiral"]["rmse_aligned_xyz_mm"][1]


def test_stiffness_sweep_starts_at_the_committed_fit():
    """E × 1 reproduces the committed CCKA fit's report (train and held-out)."""
    import json

    pat = _module("ftdcr_v4_patterns")
    folder = ROOT / "docs/figures/calibration/ftdcr_v4_ccka"
    rows = pat.stiffness_sweep(folder)
    rep = json.loads((folder / "report.json").read_text())
    assert rows[0]["E_factor"] == 1.0
    np.testing.assert_allclose(
        rows[0]["train_rmse_aligned_mm"], rep["train"]["rmse_aligned_mm"], rtol=1e-6
    )
    np.testing.assert_allclose(
        rows[0]["val_rmse_aligned_mm"], rep["validation"]["rmse_aligned_mm"], rtol=1e-6
    )


@pytest.mark.parametrize(
    "fit",
    [
        "ftdcr_v4_mujoco_selected",
        "ftdcr_v4_mujoco_backbone_selected",
        "ftdcr_v4_mujoco_softening",
        "ftdcr_v4_mujoco_helix",
        "ftdcr_v4_mujoco_helix_softening",
    ],
)
def test_committed_mujoco_fit_replays_to_its_reported_held_out_error(fit):
    """A committed MuJoCo fit's params.yaml (the parallel-routing one, without gravity; B, with
    it; the one with a drive softening; the helical one, with and without it), replayed on val.csv as the fit replayed it (rows in
    order, recorded timing, the tendon drive's cap), gives the held-out error of its
    report.json within 0.05 mm (MuJoCo builds differ in the last digits between machines)."""
    import json

    pytest.importorskip("mujoco")
    from cdcr_gym.calibration.physics import PhysicsReplay
    from cdcr_gym.calibration.report import error_stats, load_fitted
    from cdcr_gym.model.params_yaml import load_yaml

    folder = ROOT / "docs/figures/calibration" / fit
    robot, backend = load_fitted(folder / "params.yaml")
    drive = TendonDrive.of(robot)
    assert drive is not None and drive.max_tension == np.inf
    val = read_csv(ROOT / "data/real/ftdcr_v4/val.csv", robot=robot, drive=drive)
    fitted = load_yaml(folder / "params.yaml")["calibration"]["fitted"]
    values = {k: float(v) for k, v in fitted.items()}
    kwargs = {k: v for k, v in backend.items() if k != "base_orientation"}
    tip = PhysicsReplay(val, robot, drive, "mujoco", kwargs)(values).tip
    rep = json.loads((folder / "report.json").read_text())
    got = error_stats(tip, val.tip)["rmse_aligned_mm"]
    assert got == pytest.approx(rep["validation"]["rmse_aligned_mm"], abs=0.05)


@pytest.mark.parametrize("gravity", [True, False])
def test_ablation_gravity_variant_follows_the_full_fit(tmp_path, gravity):
    """The ablation switches the full fit's gravity: a fit with gravity gets a no-gravity
    variant (and keeps its payload fixed elsewhere), one without gets a gravity variant that
    also fits the payload; the other variants keep the full fit's setting."""
    from cdcr_gym.model.yaml_io import dump_yaml

    abl = _module("ftdcr_v4_mujoco_ablation")
    full = tmp_path / "full"
    full.mkdir()
    (full / "params.yaml").write_text(
        dump_yaml({"backend": {"gravity": gravity, "tip_payload": 0.004 if gravity else 0.0}})
    )
    v = abl.variants(full)
    assert set(abl.VARIANTS) < set(v)
    if gravity:
        what, extra, removed, _, added = v["no_gravity"]
        assert extra == ["--backend-arg", "gravity=false"] and added == [] and "gravity" not in v
    else:
        what, extra, removed, _, added = v["gravity"]
        assert extra == ["--backend-arg", "gravity=true"] and added == ["payload"]
        assert "no_gravity" not in v
    assert removed == []


def test_ablation_of_a_softened_fit_refits_without_the_softening(tmp_path):
    """A full fit with a drive softening refits it in every variant but one, which drops it."""
    from cdcr_gym.model.yaml_io import dump_yaml

    abl = _module("ftdcr_v4_mujoco_ablation")
    full = tmp_path / "full"
    full.mkdir()
    doc = {"backend": {"gravity": False}, "calibration": {"fitted": {"drive_softening": 27.0}}}
    (full / "params.yaml").write_text(dump_yaml(doc))
    assert abl.full_fit(full) == [*abl.FULL_FIT, "drive_softening"]
    v = abl.variants(full)
    assert v["no_softening"][2] == ["drive_softening"]
    (full / "params.yaml").write_text(dump_yaml({"backend": {"gravity": False}}))
    assert abl.full_fit(full) == abl.FULL_FIT and "no_softening" not in abl.variants(full)


def test_ablation_of_a_helical_fit_has_a_parallel_variant(tmp_path):
    """A full fit with helically wound tendons gets a variant with the pitch set to zero (the
    rest refitted as in the full fit); one with parallel tendons has none."""
    from cdcr_gym.model.yaml_io import dump_yaml

    abl = _module("ftdcr_v4_mujoco_ablation")
    full = tmp_path / "full"
    full.mkdir()
    doc = {"backend": {"gravity": False}, "robot": {"cable_pitch": -1.2}}
    (full / "params.yaml").write_text(dump_yaml(doc))
    what, extra, removed, override, added = abl.variants(full)["parallel_tendons"]
    assert override == {"cable_pitch": 0.0} and removed == [] == added == extra
    (full / "params.yaml").write_text(dump_yaml({"backend": {"gravity": False}, "robot": {}}))
    assert "parallel_tendons" not in abl.variants(full)


def test_ablation_compares_with_the_ccka_fit_the_full_fit_started_from(tmp_path):
    """The CCKA row of the ablation is the fit named by the full fit's --start-from; a fit
    without one is a ValueError naming the file."""
    from cdcr_gym.model.yaml_io import dump_yaml

    abl = _module("ftdcr_v4_mujoco_ablation")
    full = tmp_path / "full"
    full.mkdir()
    cmd = "cdcr-gym calibrate t.csv --backend mujoco --start-from 'some dir/ccka/params.yaml'"
    (full / "params.yaml").write_text(dump_yaml({"calibration": {"command": cmd}}))
    assert abl.ccka_start(full) == Path("some dir/ccka")
    (full / "params.yaml").write_text(dump_yaml({"calibration": {"command": "cdcr-gym x"}}))
    with pytest.raises(ValueError, match="params.yaml.*--start-from"):
        abl.ccka_start(full)


def _fake_fit(item: tuple) -> dict:
    name, score = item
    return {"selection_pairs_rmse_aligned_mm": score, "name": name}


def test_selection_picks_the_lowest_pair_error_and_writes_it(tmp_path):
    """The selections' shared step (both scripts): every candidate fitted, the lowest error on
    the pair rows selected, selection.json written with the rule."""
    import json

    sel = _module("ftdcr_v4_ccka_selection")
    rows, best = sel.select({"a": 4.2, "b": 3.9, "c": 4.0}, _fake_fit, "the rule", tmp_path)
    assert best == "b" and rows["c"]["name"] == "c"
    doc = json.loads((tmp_path / "selection.json").read_text())
    assert doc == {"rule": "the rule", "selected": "b", "candidates": rows}


def test_twin_evaluation_splits_the_goals_by_height_and_rewrites_its_table(tmp_path):
    ev = _module("twin_ftdcr_v4_eval", "configs")
    goals = {
        "straight": [[0.0, 0.05, 0.15], [0.0, 0.1, -0.04]],
        "random": [[0.02, 0.0, 0.1], [0.1, 0.0, -0.07], [0.0, 0.0, 0.18]],
    }
    result = {
        "env_id": "cdcr_gym/MuJoCoReach-v0",
        "params": "p.yaml",
        "env_kwargs": {},
        "episodes_per_start": 2,
        "seed": 7,
        "goals_m": goals,
        "controllers": {
            "ppo": {"final_errors_mm": {"straight": [0.3, 40.0], "random": [0.5, 9.0, 0.2]}}
        },
    }
    ev.summarise(result)
    r = result["controllers"]["ppo"]
    below = r["by_goal_height"]["below the base (z < 0)"]
    above = r["by_goal_height"]["above the base (z >= 0)"]
    assert below["episodes"] == 2 and below["median_mm"] == pytest.approx(24.5)
    assert below["success_5mm"] == 0.0
    assert above["episodes"] == 3 and above["median_mm"] == pytest.approx(0.3)
    assert r["all"]["episodes"] == 5 and r["all"]["median_mm"] == pytest.approx(0.5)
    assert r["random"]["max_mm"] == pytest.approx(9.0)
    # --table-only rebuilds the statistics and keeps the recorded command
    stripped = {"final_errors_mm": r["final_errors_mm"]}
    (tmp_path / "eval_t.json").write_text(json.dumps({**result, "controllers": {"ppo": stripped}}))
    (tmp_path / "eval_t.md").write_text(
        "# x\n\n```\npython configs/twin_ftdcr_v4_eval.py A B\n```\n"
    )
    table_only = ["--config", "c.yaml", "--params", "p.yaml", "--table-only", "--out"]
    assert ev.main([*table_only, str(tmp_path), "--tag", "t"]) == 0
    md = (tmp_path / "eval_t.md").read_text()
    assert "python configs/twin_ftdcr_v4_eval.py A B" in md
    saved = json.loads((tmp_path / "eval_t.json").read_text())
    assert saved["commands"] == ["python configs/twin_ftdcr_v4_eval.py A B"]
    assert saved["controllers"]["ppo"]["by_goal_height"] == r["by_goal_height"]
    assert "| ppo | goal below the base (z < 0) | 24.500 |" in md
    assert "Goals below the base: 2 of 5." in md
    # errors that do not match the goals are refused
    result["controllers"]["ppo"]["final_errors_mm"]["random"] = [0.1]
    with pytest.raises(ValueError, match="ppo"):
        ev.summarise(result)
    with pytest.raises(ValueError, match="not found"):
        ev.main([*table_only, str(tmp_path / "none")])
