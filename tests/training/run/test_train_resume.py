"""Resume that loses nothing, and Ctrl-C (issue 12 item 5, issue 14 item 11).

A run killed at any moment and resumed must end with the same final model, bit for bit, as an
uninterrupted run of the same config (CPU): the tests compare every tensor of the saved models.
Training runs are real ``python -m training.run.train`` subprocesses on tiny configs.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest
import torch
import yaml

REPO = Path(__file__).resolve().parents[3]
ENV = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(REPO)}

PPO_TINY = {
    "name": "tiny",
    "seed": 3,
    "total_timesteps": 1024,
    "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 2},
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2, "policy": {"net_arch": [16, 16]}},
    "eval": {"freq": 256, "n_episodes": 4},
    "checkpoint": {"freq": 128},
}
SAC_TINY = {
    "name": "tinysac",
    "algo": "sac",
    "seed": 5,
    "total_timesteps": 384,
    "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 2, "vec_env": "subproc"},
    "sac": {
        "learning_starts": 64,
        "batch_size": 32,
        "buffer_size": 1000,
        "policy": {"net_arch": [16, 16]},
    },
    "eval": {"freq": 256, "n_episodes": 4},
    "checkpoint": {"freq": 128},
}
TQC_HER_TINY = {
    "name": "tinyher",
    "algo": "tqc",
    "seed": 7,
    "total_timesteps": 384,
    "env": {
        "id": "cdcr_gym/CCKAReach-v0",
        "n_envs": 2,
        "vec_env": "batched",
        "kwargs": {"goal_conditioned": True},
    },
    "tqc": {
        "learning_starts": 200,
        "batch_size": 32,
        "buffer_size": 1000,
        "her": {"enabled": True},
        "policy": {"net_arch": [16, 16]},
    },
    "eval": {"freq": 256, "n_episodes": 4},
    "checkpoint": {"freq": 128},
}


def _write(tmp_path: Path, data: dict, name: str = "config.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def _train(*args: object, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "training.run.train", *map(str, args)],
        cwd=REPO,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _tensors(model_zip: Path) -> dict[str, torch.Tensor]:
    """Every tensor saved in a stable-baselines3 zip (policy, optimisers, extra variables)."""
    out: dict[str, torch.Tensor] = {}

    def walk(obj: object, key: str) -> None:
        if torch.is_tensor(obj):
            out[key] = obj
        elif isinstance(obj, dict):
            for k, v in obj.items():
                walk(v, f"{key}/{k}")
        elif isinstance(obj, (list, tuple)):
            for i, v in enumerate(obj):
                walk(v, f"{key}[{i}]")

    with zipfile.ZipFile(model_zip) as z:
        for name in z.namelist():
            if name.endswith(".pth"):
                walk(torch.load(io.BytesIO(z.read(name)), weights_only=False), name)
    assert out, f"no tensors in {model_zip}"
    return out


def _assert_bit_identical(a: Path, b: Path) -> None:
    ta, tb = _tensors(a), _tensors(b)
    assert ta.keys() == tb.keys()
    differ = [k for k in ta if not torch.equal(ta[k], tb[k])]
    assert not differ, f"{len(differ)} of {len(ta)} tensors differ, e.g. {differ[:3]}"


def _progress(run: Path) -> list[tuple[str, str]]:
    with open(run / "progress.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return [(r["time/total_timesteps"], r.get("train/n_updates", "")) for r in rows]


@pytest.fixture(scope="module")
def ppo_reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An uninterrupted tiny PPO run."""
    tmp = tmp_path_factory.mktemp("ppo_ref")
    run = tmp / "run"
    result = _train(_write(tmp, PPO_TINY), "--run-dir", run)
    assert result.returncode == 0, result.stderr[-3000:]
    return run


@pytest.mark.slow
def test_ppo_killed_resumed_from_a_truncated_checkpoint_is_bit_identical(
    tmp_path: Path, ppo_reference: Path
) -> None:
    run = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "training.run.train", str(_write(tmp_path, PPO_TINY))]
        + ["--run-dir", str(run)],
        cwd=REPO,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not (run / "checkpoints/state_256_steps.pkl").exists():
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)  # no handler, no cleanup: killed at a random moment
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not (run / "final_model").exists(), "the run finished before it was killed"
    states = sorted(
        int(p.name.split("_")[1]) for p in (run / "checkpoints").glob("state_*_steps.pkl")
    )
    assert len(states) >= 2 and states[-1] < PPO_TINY["total_timesteps"]
    # Killed mid-save: the newest checkpoint's model is truncated.
    newest = run / "checkpoints" / f"model_{states[-1]}_steps.zip"
    newest.write_bytes(newest.read_bytes()[: newest.stat().st_size // 2])

    result = _train(run / "config.yaml", "--run-dir", run, "--resume")
    assert result.returncode == 0, result.stderr[-3000:]
    assert f"skipping checkpoint {states[-1]}" in result.stderr
    assert f"from step {states[-2]}" in result.stdout
    _assert_bit_identical(ppo_reference / "final_model/model.zip", run / "final_model/model.zip")
    # The same updates at the same steps (not fewer after a resume), the same logs.
    assert _progress(run) == _progress(ppo_reference)
    # Not vacuous: the checkpoint it resumed from is a different model.
    with pytest.raises(AssertionError, match="tensors differ"):
        _assert_bit_identical(
            run / "checkpoints" / f"model_{states[-2]}_steps.zip", run / "final_model/model.zip"
        )


@pytest.mark.slow
def test_killed_before_the_first_checkpoint_resumes_and_restarts(
    tmp_path: Path, ppo_reference: Path
) -> None:
    """A run directory as a kill before the first checkpoint leaves it: config, run.json, logs."""
    for mode in ("--resume", None):
        run = tmp_path / f"run{mode}"
        run.mkdir()
        shutil.copy(ppo_reference / "config.yaml", run / "config.yaml")
        (run / "run.json").write_text(json.dumps({"sessions": [{"status": "running"}]}))
        shutil.copy(ppo_reference / "progress.csv", run / "progress.csv")
        (run / "checkpoints").mkdir()
        (run / "checkpoints" / ".model_128_steps.tmp.zip").write_bytes(b"PK")  # mid-save
        args = [run / "config.yaml", "--run-dir", run] + ([mode] if mode else [])
        result = _train(*args)
        assert result.returncode == 0, result.stderr[-3000:]
        assert "training it afresh from step 0" in result.stdout
        _assert_bit_identical(
            ppo_reference / "final_model/model.zip", run / "final_model/model.zip"
        )
        assert _progress(run) == _progress(ppo_reference)
        meta = json.loads((run / "run.json").read_text())
        assert meta["status"] == "complete" and meta["sessions"][0]["discarded"]


@pytest.mark.slow
@pytest.mark.parametrize("data", [SAC_TINY, TQC_HER_TINY], ids=["sac-subproc", "tqc-her-batched"])
def test_off_policy_resume_with_replay_buffer_is_bit_identical(tmp_path: Path, data: dict) -> None:
    cfg = _write(tmp_path, data)
    ref, run = tmp_path / "ref", tmp_path / "run"
    result = _train(cfg, "--run-dir", ref)
    assert result.returncode == 0, result.stderr[-3000:]
    # A kill right after the checkpoint at step 256: later files never written.
    shutil.copytree(ref, run)
    shutil.rmtree(run / "final_model")
    for path in (run / "checkpoints").iterdir():
        if int(path.name.split("_")[-2]) > 256:
            path.unlink()
    assert (run / "checkpoints/replay_buffer_256_steps.pkl").exists()
    result = _train(run / "config.yaml", "--run-dir", run, "--resume")
    assert result.returncode == 0, result.stderr[-3000:]
    assert "from step 256" in result.stdout
    _assert_bit_identical(ref / "final_model/model.zip", run / "final_model/model.zip")
    # Only the newest two checkpoints keep their replay buffer (and stay resumable).
    buffers = sorted(p.name for p in (run / "checkpoints").glob("replay_buffer_*"))
    assert len(buffers) == 2 and not (run / "checkpoints/state_128_steps.pkl").exists()
    # training.evaluate loads the model of any algo (from the run's config.yaml).
    result = subprocess.run(
        [sys.executable, "-m", "training.evaluate", str(run), "--episodes", "2"],
        cwd=REPO,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    evaluation = json.loads((run / "eval.json").read_text())
    policy = evaluation["policy"]
    assert 0.0 <= policy["success_rate"] <= 1.0 and policy["final_distance_mm"]["max"] > 0


def _interrupt(tmp_path: Path, n_signals: int) -> tuple[int, str, Path]:
    data = json.loads(json.dumps(PPO_TINY))
    data["total_timesteps"] = 10_000_000
    data["env"]["vec_env"] = "subproc"
    run = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "training.run.train", str(_write(tmp_path, data))]
        + ["--run-dir", str(run)],
        cwd=REPO,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's
    )
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not list((run / "checkpoints").glob("state_*")):
            time.sleep(0.05)
        for _ in range(n_signals):  # to the whole group, workers included, as Ctrl-C does
            os.killpg(proc.pid, signal.SIGINT)
            time.sleep(0.2)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    return proc.returncode, err, run


@pytest.mark.slow
@pytest.mark.parametrize("n_signals", [1, 2])
def test_ctrl_c_with_subproc_envs_is_exit_130_without_traceback(
    tmp_path: Path, n_signals: int
) -> None:
    code, err, run = _interrupt(tmp_path, n_signals)
    assert code == 130, err[-3000:]
    assert "Traceback" not in err and "BrokenPipeError" not in err
    lines = [line for line in err.splitlines() if line.strip() and "━" not in line]
    assert lines[-1].startswith("interrupted at step") and "--resume" in lines[-1]
    meta = json.loads((run / "run.json").read_text())
    assert meta["status"] == "interrupted"
    # Left resumable: a resume runs to a (small) new budget.
    stop = meta["sessions"][-1]["resumable_from_step"]
    result = _train(
        run / "config.yaml", "--run-dir", run, "--resume", "--total-timesteps", stop + 128
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert f"from step {stop}" in result.stdout


def test_unrestorable_envs_are_reseeded_off_the_evaluation_seeds() -> None:
    """Envs that cannot be pickled (pybullet) get a hashed seed on resume, not seed + steps."""
    from training.run.config import ExperimentConfig
    from training.run.train import fallback_env_seed

    config = ExperimentConfig()
    low = max(config.seed + config.env.n_envs, config.eval.seed + 10**5, config.evaluate.seed)
    seeds = {fallback_env_seed(s, steps) for s in range(4) for steps in range(0, 10**6, 4096)}
    assert len(seeds) == 4 * len(range(0, 10**6, 4096))  # distinct per (seed, steps)
    assert all(low < s and s + 2**16 <= 2**32 - 1 for s in seeds)
    assert fallback_env_seed(0, 100_000) != 100_000  # the old collision: eval.seed = seed + steps


@pytest.mark.slow  # ~25 s: a real training afterwards
def test_a_run_of_the_older_checkpoint_format_is_left_alone(tmp_path: Path) -> None:
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    (run / "config.yaml").write_text(yaml.safe_dump(PPO_TINY))
    (run / "run.json").write_text("{}")
    (run / "checkpoints" / "model_128_steps.zip").write_bytes(b"PK old")
    (run / "checkpoints" / "state.json").write_text('{"steps": 128}')
    for extra in (["--resume"], []):
        result = _train(run / "config.yaml", "--run-dir", run, *extra, timeout=120)
        assert result.returncode == 2 and "older format" in result.stderr
    assert (run / "checkpoints" / "model_128_steps.zip").read_bytes() == b"PK old"


def _lasting_files(run: Path) -> set[Path]:
    """The run directory's files, without the temporaries of atomic writes (``.name.tmp…``): the
    running training renames those away at any moment, so they are not files it could lose."""
    return {p.relative_to(run) for p in run.rglob("*") if not _is_atomic_write_temp(p.name)}


def _is_atomic_write_temp(name: str) -> bool:
    return name.startswith(".") and ".tmp" in name


@pytest.mark.slow
def test_a_second_training_into_a_running_run_dir_changes_nothing(tmp_path: Path) -> None:
    """Issue 23.1: a second ``train`` into the directory of a training still running (before its
    first checkpoint) once cleared it "afresh", and the first run died. Now the run directory is
    locked: the second exits 2 naming the first's pid, and the first's files are untouched; once
    the first is gone (killed: its lock is stale) a new training takes the directory over."""
    slow = {**PPO_TINY, "total_timesteps": 10**6, "checkpoint": {"freq": 10**6}}
    run = tmp_path / "run"
    first = subprocess.Popen(
        [sys.executable, "-m", "training.run.train", _write(tmp_path, slow), "--run-dir", run],
        cwd=REPO,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not (run / "progress.csv").is_file() or not any((run / "tb").glob("*")):
            assert first.poll() is None, first.stderr.read() if first.stderr else ""
            assert time.monotonic() < deadline, "the first training did not start"
            time.sleep(0.2)
        before = _lasting_files(run)
        second = _train(_write(tmp_path, slow, "second.yaml"), "--run-dir", run, "--seed", 4)
        assert second.returncode == 2, second.stdout[-2000:] + second.stderr[-2000:]
        assert "is in use by another training" in second.stderr
        assert f"pid {first.pid}" in second.stderr
        assert "afresh" not in second.stdout
        assert first.poll() is None  # the first one trains on
        assert before <= _lasting_files(run)
        assert len((run / "command.txt").read_text().splitlines()) == 1
    finally:
        first.kill()
        first.wait()
    # the killed run left its lock file behind: stale, taken over by the next training
    assert (run / ".train.lock").read_text().startswith(f"pid {first.pid} ")
    third = _train(
        _write(tmp_path, {**PPO_TINY, "total_timesteps": 128}, "third.yaml"), "--run-dir", run
    )
    assert third.returncode == 0, third.stderr[-3000:]
    assert json.loads((run / "run.json").read_text())["status"] == "complete"
