"""training.run.from_zoo: an rl_zoo3 run becomes a run directory training.evaluate reads."""

from __future__ import annotations

from pathlib import Path

from training.run.from_zoo import main

REPO = Path(__file__).resolve().parents[3]


def test_conversion_copies_model_normalisation_and_config(tmp_path: Path) -> None:
    zoo = tmp_path / "ppo" / "cdcr_gym-CCKAReach-v0_1"
    (zoo / "cdcr_gym-CCKAReach-v0").mkdir(parents=True)
    (zoo / "cdcr_gym-CCKAReach-v0.zip").write_bytes(b"model")
    (zoo / "rl_model_1000_steps.zip").write_bytes(b"checkpoint")
    (zoo / "cdcr_gym-CCKAReach-v0" / "vecnormalize.pkl").write_bytes(b"stats")
    run = tmp_path / "run"
    config = REPO / "configs" / "ppo_ccka_reach.yaml"
    assert main([str(zoo), str(run), "--config", str(config)]) == 0
    assert (run / "final_model" / "model.zip").read_bytes() == b"model"
    assert (run / "final_model" / "vecnormalize.pkl").read_bytes() == b"stats"
    assert (run / "config.yaml").read_text() == config.read_text()
    # a second conversion into the same run refuses to overwrite the model
    assert main([str(zoo), str(run), "--config", str(config)]) == 2


def test_missing_zoo_model_is_exit_2_naming_the_folder(tmp_path: Path, capsys) -> None:
    assert main([str(tmp_path), str(tmp_path / "run")]) == 2
    assert str(tmp_path) in capsys.readouterr().err
