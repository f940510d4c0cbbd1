"""Training and evaluation scripts: strict configs, smoke runs as real subprocesses, resume."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from training.run.config import ConfigError, config_from_dict, load_config, save_config

REPO = Path(__file__).resolve().parents[3]
CONFIGS = sorted((REPO / "configs").glob("*.yaml"))
ENV = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(REPO)}

#: A tiny experiment: 2 envs × 64 steps per rollout, small nets, evaluations every rollout.
TINY = {
    "name": "tiny",
    "seed": 3,
    "total_timesteps": 256,
    "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 2},
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2, "policy": {"net_arch": [16, 16]}},
    "eval": {"freq": 128, "n_episodes": 4},
    "checkpoint": {"freq": 128},
    "evaluate": {"episodes": 3, "horizons": [100, 120], "video_episodes": 1},
}


def _run(module: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *map(str, args)],
        cwd=REPO,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _tiny_config(tmp_path: Path, **changes: object) -> Path:
    data = json.loads(json.dumps(TINY))
    data.update(changes)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _csv_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# -- configs ------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_shipped_configs_load(path: Path) -> None:
    config = load_config(path)
    assert config.name == path.stem


def test_required_configs_exist() -> None:
    names = {p.name for p in CONFIGS}
    assert {"ppo_ccka_reach.yaml", "ppo_bullet_reach.yaml"} <= names


def test_misspelt_key_names_the_key() -> None:
    with pytest.raises(ConfigError, match=r"ppo\.learnig_rate.*did you mean 'learning_rate'"):
        config_from_dict({"ppo": {"learnig_rate": 1e-3}})
    with pytest.raises(ConfigError, match=r"unknown config key 'totl_timesteps'"):
        config_from_dict({"totl_timesteps": 10})


@pytest.mark.parametrize(
    "data, key",
    [
        ({"env": {"n_envs": 0}}, "env.n_envs"),
        ({"ppo": {"gamma": 1.5}}, "ppo.gamma"),
        ({"ppo": {"lr_schedule": "cosine"}}, "ppo.lr_schedule"),
        ({"env": {"vec_env": "threads"}}, "env.vec_env"),
        ({"ppo": {"batch_size": 10_000}}, "ppo.batch_size"),
        ({"normalize": {"enabled": "yes"}}, "normalize.enabled"),
        ({"evaluate": {"initial_states": ["upside_down"]}}, "evaluate.initial_states"),
        ({"ppo": {"policy": {"net_arch": [64, 0]}}}, "ppo.policy.net_arch"),
        ({"env": {"kwargs": {"goal_conditioned": True}}}, "env.kwargs.goal_conditioned"),
        ({"env": {"kwargs": {"max_episode_steps": 5}}}, "env.max_episode_steps"),
    ],
)
def test_bad_values_name_the_key(data: dict, key: str) -> None:
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        config_from_dict(data)


def test_cli_misspelt_key_fails_with_clear_message(tmp_path: Path) -> None:
    config = _tiny_config(tmp_path, normalise={"enabled": True})
    result = _run("training.run.train", config, "--run-dir", tmp_path / "run", timeout=60)
    assert result.returncode == 2
    assert "unknown config key 'normalise'" in result.stderr
    assert "did you mean 'normalize'" in result.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["missing.yaml"], "does not exist"),
        (["{cfg}", "--total-timesteps", "0"], "--total-timesteps"),
        (["{cfg}", "--seed", "-1"], "--seed"),
        (["{cfg}", "--resume"], "--resume needs --run-dir"),
        (["{cfg}", "--resume", "--run-dir", "{tmp}"], "not a training run directory"),
    ],
)
def test_train_cli_validates_arguments(tmp_path: Path, args: list[str], message: str) -> None:
    cfg = _tiny_config(tmp_path)
    args = [a.format(cfg=cfg, tmp=tmp_path) for a in args]
    result = _run("training.run.train", *args, timeout=60)
    assert result.returncode != 0
    assert message in result.stderr


def test_evaluate_cli_validates_arguments(tmp_path: Path) -> None:
    result = _run("training.evaluate", tmp_path / "nope", timeout=60)
    assert result.returncode == 2 and "RUN_DIR" in result.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["--episodes", "0"], "--episodes"),
        (["--env-id", "cdcr_gym/Nope-v0"], "--env-id"),
        # issue 23.4: another package's env (was an AttributeError)
        (["--env-id", "CartPole-v1"], "--env-id 'CartPole-v1' is not a cdcr_gym env"),
        (["--env-kwarg", "gravity"], "--env-kwarg"),
        (["--env-kwarg", "action_mode=sideways"], "action_mode"),
        (["--model", "final"], "--model final"),
        (["--tag", "a/b"], "--tag"),
    ],
)
def test_evaluate_cli_names_the_bad_argument(tmp_path: Path, args: list[str], message: str) -> None:
    run = tmp_path / "run"  # looks like a run directory; arguments are checked before loading
    (run / "best_model").mkdir(parents=True)
    (run / "best_model" / "model.zip").write_bytes(b"")
    save_config(load_config(_tiny_config(tmp_path)), run / "config.yaml")
    result = _run("training.evaluate", run, *args, timeout=60)
    assert result.returncode == 2, result.stderr[-2000:]
    assert message in result.stderr


def test_evaluate_loads_the_model_the_config_names(tmp_path: Path) -> None:
    """``evaluate.model: final`` makes ``final_model/`` evaluate's default (``--model`` wins)."""
    run = tmp_path / "run"  # a best model only: the final one is asked for and missing
    (run / "best_model").mkdir(parents=True)
    (run / "best_model" / "model.zip").write_bytes(b"")
    config = load_config(_tiny_config(tmp_path))
    config.evaluate.model = "final"
    save_config(config, run / "config.yaml")
    result = _run("training.evaluate", run, timeout=60)
    assert result.returncode == 2, result.stderr[-2000:]
    assert "--model final" in result.stderr and "final_model" in result.stderr
    # --model best overrides it: it gets past the model choice (to the empty model file)
    result = _run("training.evaluate", run, "--model", "best", timeout=60)
    assert result.returncode == 2 and "--model final" not in result.stderr


# -- smoke runs ---------------------------------------------------------------------------------
EVAL_KEYS = {"task", "policy", "oracle", "random", "conditions", "headline_condition"}
SUMMARY_KEYS = {
    "task",
    "episodes",
    "success_rate",
    "within_1mm",
    "mean_return",
    "final_distance_mm",
}
STAT_KEYS = {"mean", "median", "p95", "max"}


def _check_eval_json(path: Path, conditions: set[str]) -> dict:
    """The one report shape: a summary per policy at the headline condition and per condition."""
    data = json.loads(path.read_text())
    assert EVAL_KEYS <= data.keys()
    assert data["task"] == "Reach"
    for who in ("policy", "oracle", "random"):
        assert SUMMARY_KEYS <= data[who].keys(), who
        assert set(data[who]["final_distance_mm"]) == STAT_KEYS
        assert 0.0 <= data[who]["success_rate"] <= 1.0
    to_oracle = data["policy"]["to_oracle"]
    assert {"cable_length_distance_mm", "tension_distance_n"} <= to_oracle.keys()
    assert set(to_oracle["cable_length_distance_mm"]) == STAT_KEYS
    assert set(to_oracle["tension_distance_n"]) == STAT_KEYS
    assert set(data["conditions"]) == conditions
    for cond in data["conditions"].values():
        assert {"initial_state", "horizon", "policy", "oracle", "random"} <= cond.keys()
    # On the analytic backend the IK oracle reaches every goal.
    if data["env_id"].endswith("CCKAReach-v0"):
        oracle = data["oracle"]
        assert oracle["success_rate"] == 1.0 and oracle["final_distance_mm"]["max"] < 1e-3
    return data


@pytest.mark.slow  # ~25-55 s: 512 steps of the default config, then a full evaluation
def test_train_and_evaluate_default_config_smoke(tmp_path: Path) -> None:
    """The default config, a tiny budget: every run-directory artefact exists; evaluate works."""
    run = tmp_path / "run"
    result = _run(
        "training.run.train",
        "configs/ppo_ccka_reach.yaml",
        "--total-timesteps",
        512,
        "--run-dir",
        run,
        "--seed",
        1,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    for name in (
        "config.yaml",
        "run.json",
        "command.txt",
        "progress.csv",
        "eval_log.csv",
        "vecnormalize.pkl",
        "learning_curve.png",
        "best_model/model.zip",
        "best_model/vecnormalize.pkl",
        "final_model/model.zip",
    ):
        assert (run / name).exists(), name
    assert any((run / "tb").iterdir())
    assert list((run / "checkpoints").glob("model_*_steps.zip"))
    meta = json.loads((run / "run.json").read_text())
    assert meta["seed"] == 1 and meta["status"] == "complete"
    assert {"torch", "stable_baselines3", "gymnasium", "numpy", "cdcr_gym"} <= meta[
        "versions"
    ].keys()
    assert load_config(run / "config.yaml").total_timesteps == 512
    assert "--total-timesteps 512" in (run / "command.txt").read_text()

    result = _run("training.evaluate", run, "--episodes", 4)
    assert result.returncode == 0, result.stderr[-3000:]
    data = _check_eval_json(
        run / "eval.json",
        {"straight_100steps", "straight_200steps", "random_100steps", "random_200steps"},
    )
    assert (
        "max_distance_after_train_horizon_mm" in data["conditions"]["straight_200steps"]["policy"]
    )
    for fig in ("error_histogram.png", "workspace_errors.png", "policy_vs_oracle.png"):
        assert (run / "eval" / fig).stat().st_size > 0
    assert "success" in result.stdout  # the printed table


def test_train_runs_in_an_existing_dir_only_with_resume(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "something").write_text("x")
    result = _run("training.run.train", _tiny_config(tmp_path), "--run-dir", run, timeout=60)
    assert result.returncode == 2 and "--resume" in result.stderr


@pytest.mark.slow
def test_resume_continues_steps_and_logs(tmp_path: Path) -> None:
    cfg = _tiny_config(tmp_path)
    run = tmp_path / "run"
    result = _run("training.run.train", cfg, "--run-dir", run)
    assert result.returncode == 0, result.stderr[-3000:]
    first = _csv_rows(run / "progress.csv")
    assert [int(r["time/total_timesteps"]) for r in first] == [128, 256]
    n_events = len(list((run / "tb").iterdir()))

    # Resume to a larger budget: the counter continues from the checkpoint, logs are appended.
    result = _run("training.run.train", cfg, "--run-dir", run, "--resume", "--total-timesteps", 512)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "resuming" in result.stdout and "from step 256" in result.stdout
    rows = _csv_rows(run / "progress.csv")
    assert [int(r["time/total_timesteps"]) for r in rows] == [128, 256, 384, 512]
    for old, new in zip(first, rows[:2], strict=True):  # the first session's rows are kept
        assert old["rollout/ep_rew_mean"] == new["rollout/ep_rew_mean"]
    # 3 updates × n_epochs 2 before the last row (a row logs the previous update): continued.
    assert int(rows[-1]["train/n_updates"]) == 6
    evals = [int(r["timesteps"]) for r in _csv_rows(run / "eval_log.csv")]
    assert evals == [128, 256, 384, 512]
    assert len(list((run / "tb").iterdir())) > n_events
    meta = json.loads((run / "run.json").read_text())
    assert [s["status"] for s in meta["sessions"]] == ["complete", "complete"]
    assert meta["sessions"][1]["start_steps"] == 256 and meta["total_steps"] == 512
    assert len((run / "command.txt").read_text().splitlines()) == 2

    # The resumed run evaluates, with an H.264 MP4 of its episodes.
    result = _run("training.evaluate", run, "--episodes", 2, "--video")
    assert result.returncode == 0, result.stderr[-3000:]
    _check_eval_json(
        run / "eval.json",
        {"straight_100steps", "straight_120steps", "random_100steps", "random_120steps"},
    )
    from training.evaluate.video import probe_video

    info = probe_video(run / "eval" / "episodes.mp4")
    assert info.codec == "h264" and (info.width, info.height) == (320, 320)
    assert info.n_frames > 2


def test_resume_rejects_a_different_config(tmp_path: Path) -> None:
    cfg = _tiny_config(tmp_path)
    run = tmp_path / "run"
    run.mkdir()  # a run directory as train.py leaves it (validation happens before training)
    save_config(load_config(cfg), run / "config.yaml")
    (run / "run.json").write_text("{}")
    (tmp_path / "other").mkdir()
    other = _tiny_config(tmp_path / "other", ppo={**TINY["ppo"], "n_epochs": 3})
    result = _run("training.run.train", other, "--run-dir", run, "--resume", timeout=60)
    assert result.returncode == 2 and "ppo.n_epochs" in result.stderr


@pytest.mark.slow
def test_train_with_the_batched_vec_env(tmp_path: Path) -> None:
    cfg = _tiny_config(
        tmp_path,
        env={**TINY["env"], "vec_env": "batched", "per_env_kwargs": [{"initial_state": "random"}]},
    )
    result = _run("training.run.train", cfg, "--run-dir", tmp_path / "run")
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "run" / "best_model" / "model.zip").exists()


# -- the fast recipes (issue 12 item 1) ---------------------------------------------------------
@pytest.mark.slow  # 25-55 s each: one rollout of the real fast recipes (64 envs)
@pytest.mark.parametrize("name", ["ppo_ccka_fast", "ppo_bullet_fast", "ppo_mujoco_reach"])
def test_fast_config_trains_one_rollout(tmp_path: Path, name: str) -> None:
    """A fast recipe loads and trains its first rollout (one PPO update) end to end.

    The budget is overridden down to 256 steps; PPO still collects one full rollout of
    ``n_steps * n_envs`` steps and updates once, so the recipe's vector env, batch size and
    network all run. Its speed and accuracy are measured by commands (docs/training.md), not here.
    """
    config = load_config(REPO / "configs" / f"{name}.yaml")
    rollout = config.ppo.n_steps * config.env.n_envs
    # The recipes evaluate at the end only (periodic evaluation would cost wall time).
    assert config.eval.freq >= config.total_timesteps
    run = tmp_path / "run"
    result = _run(
        "training.run.train", f"configs/{name}.yaml", "--total-timesteps", 256, "--run-dir", run
    )
    assert result.returncode == 0, result.stderr[-3000:]
    meta = json.loads((run / "run.json").read_text())
    assert meta["status"] == "complete"
    rows = _csv_rows(run / "progress.csv")
    assert int(rows[-1]["time/total_timesteps"]) == rollout
    assert (run / "best_model" / "model.zip").exists()


# -- pins: the numbers a restructuring of training/ must leave unchanged ------------------------
#: sha256 (first 16 hex digits) of every packaged config as resolved (every default filled in)
CONFIG_DIGESTS = {
    "ppo_bullet_fast": "b9f39a4e4b5d1796",
    "ppo_bullet_friction_reach": "e6bfa8c80d23fbfa",
    "ppo_bullet_reach": "aa099e8406e0dc4c",
    "ppo_bullet_track": "a6dd709859b5b456",
    "ppo_ccka_dr_reach": "e23ce3133363d0c5",
    "ppo_ccka_fast": "42e5b5026ff0e64e",
    "ppo_ccka_obstacle": "92efcc917cfe443a",
    "ppo_ccka_pose": "dc802fb881ccbe77",
    "ppo_ccka_reach": "67fa928070089b48",
    "ppo_ccka_track": "3f579c6028f359f1",
    "ppo_mujoco_obstacle": "d8d112df7fbbdfa2",
    "ppo_mujoco_pose": "e2fad0f851f72e49",
    "ppo_mujoco_reach": "09e9246691df1e56",
    "ppo_mujoco_track": "786cf703938c01fd",
    "sac_bullet_reach": "35e2a3912018c436",
    "sac_ccka_obstacle": "f682e2b0d8a5c01d",
    "sac_ccka_obstacle_600k": "d06f809cb020c35a",
    "sac_ccka_pose": "0a245a4dea3cdd98",
    "sac_ccka_reach": "75270037d2567790",
    "sac_ccka_track": "3a94bfecc327b310",
    "sac_mujoco_obstacle": "136503a22cf0d8a7",
    "sac_mujoco_pose": "bfb9155d06697265",
    "sac_mujoco_reach": "7cb51ba263af4573",
    "sac_mujoco_track": "790203b3813273a2",
    "td3_bullet_reach": "4eaee8b0a7b57bb1",
    "td3_ccka_obstacle": "438b9f5957bf513d",
    "td3_ccka_pose": "00a7bab3dfe74b78",
    "td3_ccka_reach": "4c6d14012f87372f",
    "td3_ccka_track": "c5486e9babaf57b3",
    "td3_mujoco_obstacle": "dc917d0cd853f530",
    "td3_mujoco_pose": "26a87742868a54af",
    "td3_mujoco_reach": "8050d89743bc22da",
    "td3_mujoco_track": "3f535685daa7a571",
    "tqc_bullet_reach": "aad89fa8d481be60",
    "tqc_ccka_obstacle": "453da35c39278fc1",
    "tqc_ccka_pose": "2eeaf19ce9c747b3",
    "tqc_ccka_reach": "8e4616c1ef43e077",
    "tqc_ccka_track": "7bd0403e1aee72cb",
    "tqc_her_ccka_goalreach": "c30848fa71c41652",
    "tqc_mujoco_obstacle": "8b43aa0c7d733bf8",
    "tqc_mujoco_pose": "083e323b72e2ac6a",
    "tqc_mujoco_reach": "3aaed0dffeb9737c",
    "tqc_mujoco_track": "3916322e6e61918c",
    "twin_ftdcr_v4_mujoco_helix_reach": "e75ef8b12e9ac494",
    "twin_ftdcr_v4_mujoco_helix_reach_bc": "a28b7ed98022d94f",
    "twin_ftdcr_v4_mujoco_reach": "07bfeb9e7ed7a22f",
    "twin_ftdcr_v4_mujoco_selected_reach": "9b61decf446d6300",
    "twin_ftdcr_v4_reach": "d75609b651e21545",
}


def test_pinned_config_resolution() -> None:
    import hashlib

    from training.run.config import config_to_dict

    digests = {}
    for path in CONFIGS:
        data = json.dumps(config_to_dict(load_config(path)), sort_keys=True, default=str)
        digests[path.stem] = hashlib.sha256(data.encode()).hexdigest()[:16]
    assert digests == CONFIG_DIGESTS


@pytest.mark.parametrize("name", ["selected", "helix", "helix_bc"])
def test_twin_configs_build_the_twin_of_their_fit(name: str) -> None:
    """The twin configs of the MuJoCo fits carry what ``twin_kwargs_from_yaml`` returns for
    their ``params`` (the fit's backend arguments and drive), so the trained robot is the
    calibrated one."""
    from cdcr_gym.calibration import twin_kwargs_from_yaml

    stem = name.replace("_bc", "")
    suffix = "_bc" if name.endswith("_bc") else ""
    cfg = load_config(REPO / "configs" / f"twin_ftdcr_v4_mujoco_{stem}_reach{suffix}.yaml")
    kwargs = cfg.env.kwargs
    want = twin_kwargs_from_yaml(kwargs["params"])
    assert want.pop("action_mode") == "displacement" and kwargs["action_mode"].startswith(
        "displacement"
    )
    for key, value in want.items():
        got = kwargs[key]
        assert (list(got) if isinstance(got, (list, tuple)) else got) == (
            list(value) if isinstance(value, tuple) else value
        ), key


def test_cloned_twin_config_changes_only_the_start_and_the_schedule() -> None:
    """The helical twin's behaviour-cloning config trains on the same env and evaluates the same
    way as the plain recipe; it adds the oracle's demonstrations and a lower learning rate over
    fewer steps."""
    from training.run.config import config_to_dict

    plain = config_to_dict(load_config(REPO / "configs/twin_ftdcr_v4_mujoco_helix_reach.yaml"))
    bc = config_to_dict(load_config(REPO / "configs/twin_ftdcr_v4_mujoco_helix_reach_bc.yaml"))
    changed = {k for k in plain if plain[k] != bc[k]}
    assert changed == {"name", "total_timesteps", "demonstrations", "ppo"}
    assert {k for k in plain["ppo"] if plain["ppo"][k] != bc["ppo"][k]} == {"learning_rate"}
    assert bc["demonstrations"]["episodes"] > 0 and plain["demonstrations"]["episodes"] == 0


#: every off-policy config with a PPO config of the same task: (algo, task), e.g. ("sac", "mujoco_pose")
OFF_POLICY_TWINS = sorted(
    (p.stem.split("_", 1)[0], p.stem.split("_", 1)[1])
    for p in CONFIGS
    if p.stem.split("_", 1)[0] in ("sac", "td3", "tqc")
    and (REPO / "configs" / f"ppo_{p.stem.split('_', 1)[1]}.yaml").is_file()
)


@pytest.mark.parametrize(("algo", "task"), OFF_POLICY_TWINS)
def test_off_policy_configs_share_the_ppo_configs_env_and_evaluation(algo: str, task: str) -> None:
    """The benchmark compares learners on one env: an off-policy config of a task has its PPO
    config's env (all but the number of envs), periodic-evaluation episodes and evaluation
    episodes (the saved model evaluated may differ)."""
    import dataclasses

    ppo = load_config(REPO / "configs" / f"ppo_{task}.yaml")
    other = load_config(REPO / "configs" / f"{algo}_{task}.yaml")
    assert other.algo == algo
    assert dataclasses.replace(other.env, n_envs=ppo.env.n_envs) == ppo.env
    assert dataclasses.replace(other.eval, freq=ppo.eval.freq) == ppo.eval
    # the same evaluation episodes; which saved model is evaluated (best or final) is the learner's
    assert dataclasses.replace(other.evaluate, model=ppo.evaluate.model) == ppo.evaluate


def test_the_600k_obstacle_config_is_the_benchmark_config_trained_longer() -> None:
    """sac_ccka_obstacle_600k (the config that meets the Obstacle target) is the benchmark's
    sac_ccka_obstacle with more steps, a buffer for all of them and the final model evaluated."""
    import dataclasses

    base = load_config(REPO / "configs" / "sac_ccka_obstacle.yaml")
    long = load_config(REPO / "configs" / "sac_ccka_obstacle_600k.yaml")
    assert (long.total_timesteps, long.sac.buffer_size, long.evaluate.model) == (
        600_000,
        600_000,
        "final",
    )
    same = dataclasses.replace(
        long,
        name=base.name,
        total_timesteps=base.total_timesteps,
        sac=dataclasses.replace(long.sac, buffer_size=base.sac.buffer_size),
        evaluate=dataclasses.replace(long.evaluate, model=base.evaluate.model),
    )
    assert same == base


#: eval_log.csv of the tiny run below (seed 3, 256 steps): (timesteps, mean_error_mm, mean_reward)
PINNED_EVAL_LOG = [(128, 228.553791, -22.681192), (256, 229.84247, -22.750727)]


def test_pinned_tiny_training_run(tmp_path: Path) -> None:
    """A tiny PPO run on a fixed seed: its periodic evaluations as pinned on another machine,
    to 1e-5 relative (torch's CPU kernels differ in the last bits between machines; the same
    seed repeats bit for bit on one machine: ``test_train_resume``)."""
    run = tmp_path / "run"
    result = _run("training.run.train", _tiny_config(tmp_path), "--run-dir", run, timeout=120)
    assert result.returncode == 0, result.stderr[-3000:]
    rows = [
        (
            int(r["timesteps"]),
            round(float(r["mean_error_mm"]), 6),
            round(float(r["mean_reward"]), 6),
        )
        for r in _csv_rows(run / "eval_log.csv")
    ]
    assert [r[0] for r in rows] == [p[0] for p in PINNED_EVAL_LOG]
    for got, want in zip(rows, PINNED_EVAL_LOG):
        assert got[1:] == pytest.approx(want[1:], rel=1e-5), (got, want)


@pytest.mark.slow  # two tiny trainings: 8-25 s
def test_train_prints_a_progress_bar_and_a_summary_and_tables_only_when_verbose(
    tmp_path: Path,
) -> None:
    """Issue 23.12: SB3's table of every rollout (~6 500 lines in a one-minute run) only with
    ``--verbose``; by default the progress bar and a few lines of summary."""
    quiet = _run("training.run.train", _tiny_config(tmp_path), "--run-dir", tmp_path / "q")
    assert quiet.returncode == 0, quiet.stderr[-3000:]
    assert "rollout/" not in quiet.stdout and "| time/" not in quiet.stdout
    assert len(quiet.stdout.splitlines()) <= 10, quiet.stdout
    assert "done: 256 steps" in quiet.stdout and "last evaluation (step 256)" in quiet.stdout
    assert "cdcr-gym evaluate" in quiet.stdout
    loud = _run(
        "training.run.train", _tiny_config(tmp_path), "--run-dir", tmp_path / "v", "--verbose"
    )
    assert loud.returncode == 0, loud.stderr[-3000:]
    assert "rollout/" in loud.stdout and "time/" in loud.stdout


@pytest.mark.slow  # ~25 s: a real (tiny) training run on the Obstacle env
def test_curriculum_raises_the_obstacle_difficulty_before_each_rollout(tmp_path: Path) -> None:
    """A curriculum run logs the difficulty it set before each rollout: linear from ``start``
    to 1 over ``steps`` env steps (the in-training evaluation runs the full task)."""
    cfg = _tiny_config(
        tmp_path,
        env={"id": "cdcr_gym/CCKAObstacle-v0", "n_envs": 2, "vec_env": "batched"},
        total_timesteps=512,
        curriculum={"steps": 384, "start": 0.25},
    )
    run = tmp_path / "run"
    result = _run("training.run.train", cfg, "--run-dir", run)
    assert result.returncode == 0, result.stderr[-3000:]
    rows = _csv_rows(run / "progress.csv")
    logged = [float(r["charts/difficulty"]) for r in rows if r.get("charts/difficulty")]
    # rollouts of 128 steps start at 0, 128, 256, 384: 0.25, 0.5, 0.75, 1.0
    assert logged == pytest.approx([0.25, 0.5, 0.75, 1.0])
