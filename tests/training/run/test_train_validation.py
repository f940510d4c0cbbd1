"""Config errors are found before anything is written (issue 14, item 9).

Each case runs the trainer's ``main`` (what ``python -m training.run.train`` runs) and asserts exit
status 2, a message naming the key, and that the run directory was not created.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from training.run.config import ConfigError, config_from_dict, load_config
from training.run.train import main

TINY = {
    "name": "tiny",
    "seed": 3,
    "total_timesteps": 256,
    "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 2},
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2, "policy": {"net_arch": [16, 16]}},
    "eval": {"freq": 128, "n_episodes": 4},
    "checkpoint": {"freq": 128},
}


def _config(tmp_path: Path, **changes: object) -> Path:
    data = json.loads(json.dumps(TINY))
    for dotted, value in changes.items():
        *parents, key = dotted.split("__")
        node = data
        for p in parents:
            node = node.setdefault(p, {})
        node[key] = value
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _train_fails(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], config: Path, *extra: str
) -> str:
    run = tmp_path / "run"
    code = main([str(config), "--run-dir", str(run), *extra])
    err = capsys.readouterr().err
    assert code == 2, err
    assert not run.exists(), "a run directory was created for a config that cannot train"
    assert "Traceback" not in err
    return err


@pytest.mark.parametrize(
    "changes, message",
    [
        # a typo and a bad value in env.kwargs
        ({"env__kwargs": {"action_mod": "tension"}}, "env.kwargs: cannot make"),
        ({"env__kwargs": {"action_mode": "sideways"}}, "env.kwargs: cannot make"),
        # bad robot parameters: an unknown field, then an invalid value
        ({"env__kwargs": {"params": {"n_disk": 3}}}, "env.kwargs.params"),
        ({"env__kwargs": {"params": {"max_tension": -5.0}}}, "env.kwargs.params"),
        ({"env__kwargs": {"params": 7}}, "env.kwargs.params must be a mapping"),
        # an unknown key in one per_env_kwargs entry
        (
            {"env__per_env_kwargs": [{"initial_state": "random"}, {"initial_stat": "random"}]},
            "env.per_env_kwargs[1]",
        ),
        # another package's env
        ({"env__id": "CartPole-v1"}, "env.id 'CartPole-v1' is not a cdcr_gym env"),
        # a seed beyond numpy's range
        ({"seed": 2**32}, "seed must be an integer in [0, 2**32 - 1"),
        # algorithm sections
        ({"sac": {"batch_size": 64}}, "config section 'sac' is for algo: sac"),
        ({"algo": "td3", "ppo": None, "td3": {"polcy_delay": 3}}, "did you mean 'policy_delay'"),
        ({"algo": "a2c"}, "algo must be one of"),
        # a curriculum on a task without one, and out-of-range curriculum values
        ({"curriculum": {"steps": 1000, "start": 0.5}}, "curriculum.steps: the Reach task"),
        ({"curriculum": {"steps": -1}}, "curriculum.steps must be an integer >= 0"),
        ({"curriculum": {"steps": 10, "start": 0.0}}, "curriculum.start must be in (0, 1]"),
        ({"curriculum": {"stps": 10}}, "did you mean 'steps'"),
        # which saved model evaluate loads
        ({"evaluate": {"model": "last"}}, "evaluate.model must be one of"),
    ],
)
def test_bad_config_is_exit_2_before_the_run_dir(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], changes: dict, message: str
) -> None:
    data = dict(changes)
    cfg = _config(tmp_path, **data)
    if data.get("ppo", 0) is None:  # drop the ppo section for another algo
        raw = yaml.safe_load(cfg.read_text())
        raw.pop("ppo")
        cfg.write_text(yaml.safe_dump(raw))
    err = _train_fails(tmp_path, capsys, cfg)
    assert message in err


def test_seed_argument_beyond_range(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = _train_fails(tmp_path, capsys, _config(tmp_path), "--seed", str(2**32))
    assert "--seed must be an integer in [0, 2**32 - 1]" in err


def test_non_utf8_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "latin1.yaml"
    cfg.write_bytes("name: t\u00e9st\n".encode("latin-1"))
    err = _train_fails(tmp_path, capsys, cfg)
    assert "is not UTF-8 text" in err and "latin1.yaml" in err


def test_directory_as_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "configs.yaml").mkdir()
    err = _train_fails(tmp_path, capsys, tmp_path / "configs.yaml")
    assert "is a directory" in err


def test_duplicate_yaml_key_names_key_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "dup.yaml"
    cfg.write_text("name: dup\nenv:\n  n_envs: 2\n  vec_env: dummy\n  n_envs: 4\n")
    err = _train_fails(tmp_path, capsys, cfg)
    assert "duplicate key 'n_envs' on line 5 (first given on line 3)" in err
    # Nested and top-level mappings alike; the loader is the one load_config uses.
    cfg.write_text("seed: 1\nname: a\nseed: 2\n")
    with pytest.raises(ConfigError, match="duplicate key 'seed' on line 3"):
        load_config(cfg)


def test_cuda_without_a_gpu_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import torch

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    err = _train_fails(tmp_path, capsys, _config(tmp_path, runtime={"device": "cuda"}))
    assert "runtime.device: 'cuda', but torch sees no CUDA GPU" in err
    with pytest.raises(ConfigError, match="runtime.device"):
        config_from_dict({"runtime": {"device": "cuda:x"}})


@pytest.mark.parametrize(
    "data, message",
    [
        ({"algo": "sac", "sac": {"her": {"enabled": True}}}, "goal_conditioned: true"),
        (
            {"algo": "ppo", "env": {"kwargs": {"goal_conditioned": True}}},
            "env.kwargs.goal_conditioned",
        ),
        (
            {
                "algo": "tqc",
                "env": {"n_envs": 4, "kwargs": {"goal_conditioned": True}},
                "tqc": {"learning_starts": 100, "her": {"enabled": True}},
            },
            r"tqc.learning_starts \(100\) must be >= env.max_episode_steps \* env.n_envs",
        ),
        ({"algo": "tqc", "tqc": {"top_quantiles_to_drop_per_net": 25}}, "top_quantiles"),
        ({"algo": "td3", "td3": {"action_noise_std": -1.0}}, "td3.action_noise_std"),
        ({"algo": "sac", "sac": {"tau": 0.0}}, r"sac\.tau"),
        ({"algo": "sac", "sac": {"her": {"goal_selection_strategy": "past"}}}, "goal_selection"),
    ],
)
def test_off_policy_values_name_the_key(data: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        config_from_dict(data)


def test_saved_config_holds_only_the_selected_algo(tmp_path: Path) -> None:
    from training.run.config import save_config

    config = config_from_dict({"algo": "td3", "td3": {"policy_delay": 3}})
    save_config(config, tmp_path / "c.yaml")
    raw = yaml.safe_load((tmp_path / "c.yaml").read_text())
    assert raw["algo"] == "td3" and raw["td3"]["policy_delay"] == 3
    assert not {"ppo", "sac", "tqc"} & raw.keys()
    assert load_config(tmp_path / "c.yaml") == config


@pytest.mark.parametrize("text", ["", "# only a comment\n\n# and another\n", "---\n"])
def test_an_empty_config_is_an_error_not_a_default_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, text: str
) -> None:
    """Issue 23.3: a 0-byte (or comments-only) config once started a 1 M-step default run."""
    from training.run import train as train_module

    def must_not_train(*args: object, **kwargs: object) -> int:
        raise AssertionError("an empty config started a training run")

    monkeypatch.setattr(train_module, "train", must_not_train)
    cfg = tmp_path / "empty.yaml"
    cfg.write_text(text)
    with pytest.raises(ConfigError, match="is empty"):
        load_config(cfg)
    err = _train_fails(tmp_path, capsys, cfg)
    assert "empty.yaml" in err and "is empty" in err
