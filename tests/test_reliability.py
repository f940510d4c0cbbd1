"""Regression tests for the adversarial probe's findings (one test per item, its reproduction).

Items 4, 6, 7 (bullet copies, GUI without display, few disks) are in tests/test_bullet*.py;
items 5, 9, 10, 11 (bench, config errors, corrupt files, Ctrl-C) in tests/test_training_errors.py.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym import kinematics as K
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.controllers import AnalyticIKController
from cdcr_gym.envs.factory import split_kwargs
from cdcr_gym.model import statics
from cdcr_gym.model.params import RobotParams

ENV_ID = "cdcr_gym/CCKAReach-v0"


# 1. observations left their space for valid-looking parameters -----------------------------
@pytest.mark.parametrize("kwargs", [{"max_tension": 200.0}, {"youngs_modulus": 1e9}])
def test_parameters_that_bend_beyond_pi_are_rejected_with_the_reason(kwargs):
    with pytest.raises(ValueError, match="180°"):
        RobotParams(**kwargs)


def test_the_largest_allowed_tension_keeps_observations_in_their_space():
    # just below the rejection threshold: absolute tension actions at the extremes
    limit = RobotParams().max_tension * np.pi / RobotParams().section_bend_limits[0]
    env = gym.make(ENV_ID, params=RobotParams(max_tension=0.999 * limit), action_mode="tension")
    env.reset(seed=0)
    for action in ([1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1]):
        obs, *_ = env.step(np.array(action, dtype=np.float32))
        assert env.observation_space.contains(obs), obs


# 2. goals far off the workspace were projected beyond the tension limit ---------------------
# (a goal beyond 10 robot lengths is refused: tests/test_hostile_envs.py)
@pytest.mark.parametrize("goal", [(0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (3.0, 3.0, 3.0)])
def test_far_goals_are_projected_onto_the_reachable_set_and_the_oracle_reaches_them(goal):
    env = gym.make(ENV_ID, action_mode="tension")
    obs, info = env.reset(seed=0, options={"goal": goal})
    p = env.unwrapped.params
    theta, phi, residual = K.arc_from_tip(info["goal"], p.length)
    assert residual < 1e-9
    assert theta <= statics.bending_limit(phi, p) + 1e-9  # within the tension limit
    controller = AnalyticIKController.from_env(env)
    _, _, _, _, info = env.step(controller(obs))
    assert info["distance"] < 1e-6


# 3. NaN and out-of-domain input passed silently through the model ----------------------------
@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: K.tip_from_arc(np.nan, 0.0, 0.641), "theta"),
        (lambda: K.lengths_from_arc(0.1, np.nan, 0.641, 0.029), "phi"),
        (lambda: K.backbone_points(np.nan, 0.0, 0.641), "theta"),
        (lambda: K.tip_rotation(0.1, np.inf), "phi"),
        (lambda: statics.tensions_from_arc(np.nan, 0.0, RobotParams()), "theta"),
        (lambda: statics.bending_limit(np.nan, RobotParams()), "phi"),
        (lambda: K.arc_from_lengths([-0.6, 0.6, 0.6], 0.029), "lengths"),
        (lambda: statics.arc_from_tensions([-1.0, 0.0, 0.0], RobotParams()), "tensions"),
    ],
)
def test_non_finite_or_out_of_domain_model_input_raises_value_error_naming_it(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_analytic_backend_rejects_negative_tensions_like_the_bullet_backend():
    backend = AnalyticBackend()
    with pytest.raises(ValueError, match="tensions"):
        backend.reset(np.array([[-1.0, 0.0, 0.0]]))
    with pytest.raises(ValueError, match="tensions"):
        backend.equilibrium(np.array([[0.0, np.nan, 0.0]]))


# 8. a documented backend argument missing from the factory's pass-through list ---------------
def test_every_backend_constructor_argument_reaches_the_backend():
    from cdcr_gym.backends.bullet import BulletBackend
    from cdcr_gym.envs.factory import keyword_names

    names = set(keyword_names(BulletBackend)) - {"params"}
    assert "damping_ratio" in names
    backend_kw = split_kwargs("Bullet", "Reach", {n: None for n in names})[1]
    assert set(backend_kw) == names
    env = gym.make("cdcr_gym/BulletReach-v0", damping_ratio=0.5, gravity=False)
    assert env.unwrapped.backend.damping_ratio == 0.5
    env.close()


# 12. actions given as strings or complex numbers were accepted silently ----------------------
@pytest.mark.parametrize("action", ["abc", "0.1", {"a": 1}, [1j, 0, 0], [0, None, 0]])
def test_non_real_actions_raise_value_error_naming_action(action):
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.unwrapped.step(action)


# 4. a copied bullet env shared the original's pybullet client ---------------------------------
def test_bullet_envs_refuse_pickle_and_deepcopy_but_subproc_vec_env_works():
    import copy
    import pickle

    import cloudpickle
    from stable_baselines3.common.vec_env import SubprocVecEnv

    env = gym.make("cdcr_gym/BulletReach-v0", gravity=False)
    env.reset(seed=0)
    for dump in (pickle.dumps, cloudpickle.dumps, copy.deepcopy):
        with pytest.raises(TypeError, match="cannot be pickled or copied"):
            dump(env)
    env.close()
    venv = SubprocVecEnv(
        [lambda: gym.make("cdcr_gym:BulletReach-v0", gravity=False) for _ in range(2)]
    )
    venv.seed(0)
    obs = venv.reset()
    obs, reward, done, info = venv.step(np.zeros((2, 3), dtype=np.float32))
    assert obs.shape == (2, 18) and np.isfinite(obs).all()
    venv.close()


# 5. the bench's default config was relative to the working directory -------------------------
def test_bench_default_config_does_not_depend_on_the_working_directory(tmp_path, monkeypatch):
    from training.studies import bench

    monkeypatch.chdir(tmp_path)
    assert bench.DEFAULT_CONFIG.is_absolute() and bench.DEFAULT_CONFIG.is_file()
    with pytest.raises(SystemExit) as exc:
        bench.main(["--config", "configs/ppo_ccka_reach.yaml"])  # relative to tmp: missing
    assert exc.value.code == 2


def test_bench_unwritable_out_fails_before_benchmarking(tmp_path, capsys):
    from training.studies import bench

    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(SystemExit) as exc:
        bench.main(["--out", str(blocker / "sub" / "bench.md")])  # a file as a directory
    assert exc.value.code == 2
    assert "not writable" in capsys.readouterr().err


# 10. evaluate on a truncated/empty model or a corrupt VecNormalize: a traceback ---------------
def _run_dir(tmp_path):
    import shutil
    from pathlib import Path

    run = tmp_path / "run"
    (run / "best_model").mkdir(parents=True)
    config = Path(__file__).resolve().parents[1] / "configs" / "ppo_ccka_reach.yaml"
    shutil.copyfile(config, run / "config.yaml")
    return run


def test_evaluate_on_an_empty_model_zip_is_exit_2_naming_the_file(tmp_path, capsys):
    from training.evaluate import agent as evaluate

    run = _run_dir(tmp_path)
    (run / "best_model" / "model.zip").write_bytes(b"")
    assert evaluate.main([str(run), "--episodes", "1"]) == 2
    assert "model.zip" in capsys.readouterr().err
    assert not (run / "eval").exists()  # nothing written


def test_evaluate_on_a_corrupt_vecnormalize_is_exit_2_naming_the_file(tmp_path, capsys):
    from stable_baselines3 import PPO

    from training.evaluate import agent as evaluate

    run = _run_dir(tmp_path)
    PPO("MlpPolicy", gym.make(ENV_ID), n_steps=32, batch_size=32, device="cpu").save(
        run / "best_model" / "model.zip"
    )
    (run / "best_model" / "vecnormalize.pkl").write_bytes(b"\x80\x04truncated")
    assert evaluate.main([str(run), "--episodes", "1"]) == 2
    assert "vecnormalize.pkl" in capsys.readouterr().err


# 10. train/evaluate into a directory that cannot be written: a traceback --------------------
def _unwritable(monkeypatch):
    """A read-only mount, as root sees it: creating a file fails with EROFS."""
    import errno
    import tempfile

    def refuse(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(tempfile, "TemporaryFile", refuse)


def test_train_into_a_path_below_a_file_is_exit_2_naming_run_dir(tmp_path, capsys):
    from training.run import train

    (tmp_path / "afile").write_text("x")
    target = tmp_path / "afile" / "run"
    assert train.main([str(_CONFIG), "--run-dir", str(target)]) == 2
    err = capsys.readouterr().err
    assert "--run-dir" in err and "is not a directory" in err and "Traceback" not in err


def test_train_into_a_read_only_directory_is_exit_2_and_creates_nothing(
    tmp_path, capsys, monkeypatch
):
    from training.run import train

    _unwritable(monkeypatch)
    target = tmp_path / "runs" / "run"
    assert train.main([str(_CONFIG), "--run-dir", str(target)]) == 2
    err = capsys.readouterr().err
    assert "--run-dir" in err and "Read-only file system" in err
    assert not (tmp_path / "runs").exists()


def test_evaluate_into_a_read_only_run_dir_is_exit_2_naming_it(tmp_path, capsys, monkeypatch):
    from training.evaluate import agent as evaluate

    run = _run_dir(tmp_path)
    (run / "best_model" / "model.zip").write_bytes(b"")
    _unwritable(monkeypatch)
    assert evaluate.main([str(run), "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "RUN_DIR" in err and "Read-only file system" in err


_CONFIG = (
    __import__("pathlib").Path(__file__).resolve().parents[1] / "configs" / "ppo_ccka_reach.yaml"
)
