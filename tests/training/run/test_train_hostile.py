"""Hostile cases of ``cdcr-gym train``: changed configs on --resume, odd run directories, full
disks and read-only directories (exit 2 with a message, never a traceback, checkpoints kept)."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest
import yaml

from training.run import train as train_mod
from training.run.config import load_config, save_config
from training.run.rundir import Checkpoint, RunDir

TINY = {
    "name": "tiny",
    "seed": 3,
    "total_timesteps": 256,
    "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 2},
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 1, "policy": {"net_arch": [8]}},
    "eval": {"freq": 128, "n_episodes": 2},
    "checkpoint": {"freq": 128},
    "evaluate": {"episodes": 2, "horizons": [50]},
}


def _config(path: Path, **changes: object) -> Path:
    data = json.loads(json.dumps(TINY))
    for key, value in changes.items():
        node = data
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data))
    return path


def _fake_run(tmp_path: Path, steps: int | None = None) -> Path:
    """A run directory as training leaves it, without training (config.yaml, run.json)."""
    run = tmp_path / "run"
    run.mkdir()
    save_config(load_config(_config(tmp_path / "orig.yaml")), run / "config.yaml")
    (run / "run.json").write_text("{}")
    return run


# -- 1. --resume honours or refuses every changed key -------------------------------------------
def test_resume_honours_a_raised_total_timesteps_in_the_config_file(tmp_path: Path) -> None:
    run = _fake_run(tmp_path)
    cfg = _config(tmp_path / "more.yaml", total_timesteps=4096)
    args = train_mod._parse_args([str(cfg), "--run-dir", str(run), "--resume"])
    config, _ = train_mod._resolve(args)
    assert config.total_timesteps == 4096  # was silently kept at 256: "nothing to do"


@pytest.mark.parametrize(
    "key, value",
    [("seed", 4), ("env.id", "cdcr_gym/CCKATrack-v0"), ("name", "other"), ("ppo.n_epochs", 3)],
)
def test_resume_refuses_other_changes_naming_the_key_and_both_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, value: object
) -> None:
    run = _fake_run(tmp_path)
    cfg = _config(tmp_path / "changed.yaml", **{key: value})
    assert train_mod.main([str(cfg), "--run-dir", str(run), "--resume"]) == 2
    err = capsys.readouterr().err
    old = {"seed": 3, "env.id": TINY["env"]["id"], "name": "tiny", "ppo.n_epochs": 1}[key]
    assert key in err and repr(value) in err and repr(old) in err, err
    assert "Traceback" not in err


def test_resume_refuses_a_budget_below_the_steps_already_trained(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _fake_run(tmp_path)
    monkeypatch.setattr(RunDir, "latest_checkpoint", lambda self: 200)
    cfg = _config(tmp_path / "less.yaml", total_timesteps=128)
    assert train_mod.main([str(cfg), "--run-dir", str(run), "--resume"]) == 2
    err = capsys.readouterr().err
    assert "total_timesteps 128" in err and "200" in err


# -- 4. run directories ---------------------------------------------------------------------------
def test_a_dangling_symlink_run_dir_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "nowhere")
    cfg = _config(tmp_path / "c.yaml")
    assert train_mod.main([str(cfg), "--run-dir", str(link)]) == 2
    err = capsys.readouterr().err
    assert "--run-dir" in err and "dangling" in err and "Traceback" not in err
    assert not (tmp_path / "nowhere").exists()


def test_resume_on_a_read_only_run_dir_is_a_usage_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _fake_run(tmp_path)
    if os.geteuid() != 0:
        run.chmod(0o555)
    else:  # root writes anywhere: make the directory look read-only instead
        import training.run.config as config_mod

        real = os.access
        monkeypatch.setattr(
            config_mod.os, "access", lambda p, m: False if Path(p) == run else real(p, m)
        )
    try:
        status = train_mod.main([str(run / "config.yaml"), "--run-dir", str(run), "--resume"])
    finally:
        run.chmod(0o755)
    err = capsys.readouterr().err
    assert status == 2 and "--run-dir" in err and "not writable" in err, err


def test_an_os_error_while_training_is_exit_2_without_traceback(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def read_only(*args: object, **kwargs: object) -> int:
        raise OSError(errno.EROFS, "Read-only file system", str(tmp_path / "run" / "run.json"))

    monkeypatch.setattr(train_mod, "train", read_only)
    cfg = _config(tmp_path / "c.yaml")
    assert train_mod.main([str(cfg), "--run-dir", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert "Read-only file system" in err and "run.json" in err


def test_a_full_disk_during_training_stops_with_exit_2_and_keeps_the_checkpoints(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import training.run.checkpoints as ckpt_mod

    real = ckpt_mod.atomic_write
    calls = {"n": 0}

    def filling(path: Path, write):  # type: ignore[no-untyped-def]
        # the first checkpoint (model, vecnormalize?, state) goes through; then the disk is full
        if "_256_" in path.name:

            def partial(tmp: Path) -> None:
                tmp.write_bytes(b"half")
                raise OSError(errno.ENOSPC, "No space left on device", str(tmp))

            return real(path, partial)
        calls["n"] += 1
        return real(path, write)

    monkeypatch.setattr(ckpt_mod, "atomic_write", filling)
    run = tmp_path / "run"
    status = train_mod.main([str(_config(tmp_path / "c.yaml")), "--run-dir", str(run)])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "No space left on device" in err and "--resume" in err and "Traceback" not in err
    assert "step 128" in err
    assert calls["n"] >= 2
    Checkpoint.read(RunDir(run), 128)  # the earlier checkpoint is complete
    leftovers = [p.name for p in (run / "checkpoints").iterdir() if ".tmp" in p.name]
    assert leftovers == []


def test_resume_with_a_raised_budget_trains_on_to_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "run"
    cfg = _config(tmp_path / "c.yaml", total_timesteps=128)
    assert train_mod.main([str(cfg), "--run-dir", str(run)]) == 0
    more = _config(tmp_path / "more.yaml", total_timesteps=256)
    capsys.readouterr()
    assert train_mod.main([str(more), "--run-dir", str(run), "--resume"]) == 0
    out = capsys.readouterr().out
    assert "nothing to do" not in out and "from step 128" in out, out
    assert RunDir(run).latest_checkpoint() == 256
    assert load_config(run / "config.yaml").total_timesteps == 256  # the directory says so
    # resuming again from its own config.yaml: complete, nothing to do
    assert train_mod.main([str(run / "config.yaml"), "--run-dir", str(run), "--resume"]) == 0
    assert "nothing to do" in capsys.readouterr().out


def test_a_full_disk_while_trimming_a_log_on_resume_keeps_the_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import builtins

    from training.run.logs import truncate_csv

    log = tmp_path / "progress.csv"
    log.write_text("step,x\n1,a\n2,b\n3,c\n")
    real_open = builtins.open

    def full_open(file, mode="r", *args, **kwargs):  # type: ignore[no-untyped-def]
        handle = real_open(file, mode, *args, **kwargs)
        if "w" in mode:
            handle.close()
            raise OSError(errno.ENOSPC, "No space left on device", str(file))
        return handle

    monkeypatch.setattr(builtins, "open", full_open)
    with pytest.raises(OSError):
        truncate_csv(log, "step", 2)
    monkeypatch.undo()
    assert log.read_text() == "step,x\n1,a\n2,b\n3,c\n"
    assert [p.name for p in tmp_path.iterdir()] == ["progress.csv"]
