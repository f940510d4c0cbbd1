"""Smoke runs of ``cdcr-gym bench-physics`` (speed and accuracy modes, tiny sizes)."""

from __future__ import annotations

import json

import numpy as np

from training.studies import bench_physics


def test_speed_table_has_every_row_and_ratios_to_bullet(capsys):
    bench_physics.main(["--repeats", "1", "--steps", "4"])
    out = capsys.readouterr().out
    for row in (
        "BulletReach-v0(links_per_span=1)",
        "MuJoCoReach-v0 (default)",
        "MuJoCo, bullet's discretisation",
        "MuJoCo vector env, 64 envs",
    ):
        assert row in out
    assert "| 1.00× |" in out  # bullet is the reference of the ratios


def test_accuracy_table_reads_a_reference_json(tmp_path):
    from cdcr_gym.backends.mujoco import MuJoCoBackend
    from cdcr_gym.params import RobotParams

    # a reference that is the default model itself: zero error in its row
    tensions = [[40.0, 0.0, 0.0], [0.0, 20.0, 60.0]]
    tips = MuJoCoBackend(RobotParams(), gravity=False).equilibrium(np.array(tensions)).tip
    cases = [
        {"robot": "paper", "gravity": False, "tensions": t, "tip": tip.tolist()}
        for t, tip in zip(tensions, tips)
    ]
    path = tmp_path / "ref.json"
    path.write_text(json.dumps({"cases": cases}))
    name, rows = bench_physics.accuracy_table(quick=True, repeats=1, steps=3, reference=path)
    assert str(path) in name
    by_config = {
        (r["joint"], r["routing"], r["links_per_span"]): r for r in rows if r["backend"] == "mujoco"
    }
    assert by_config["ball", "corrected", 1]["paper g=off"][0] < 1e-12
    assert by_config["cardan", "disk", 1]["paper g=off"][0] > 0.005  # bullet's old model is off
    bullet = {r["routing"]: r for r in rows if r["backend"] == "pybullet"}
    assert set(bullet) == {"corrected", "disk"}
    assert bullet["disk"]["paper g=off"][0] > 0.005
    assert bullet["corrected"]["paper g=off"][0] < 0.005 * RobotParams().length


def test_default_reference_is_the_committed_cosserat_rod():
    # the module moved into training/studies/; a wrong parents[] index silently fell back to the
    # converged chain
    assert bench_physics.REFERENCE_PATH.exists()
    assert bench_physics.REFERENCE_PATH.name == "cosserat_reference.json"
    name, _ = bench_physics.accuracy_table(quick=True, repeats=1, steps=3)
    assert name.startswith("Cosserat rod"), name
