"""envs.factory and cdcr_gym.registration: ids from one table, keywords routed by signature."""

from __future__ import annotations

import gymnasium as gym
import pytest

import cdcr_gym
from cdcr_gym import registration
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.envs import factory
from cdcr_gym.model.params import RobotParams
from cdcr_gym.tasks.reach import Reach


def test_every_row_of_the_table_is_registered_in_both_forms():
    ids = registration.env_ids() + registration.env_ids(short=True)
    assert len(ids) == 2 * len(registration.BACKENDS) * len(registration.TASKS)
    for env_id in ids:
        spec = gym.registry[env_id]
        assert spec.max_episode_steps == cdcr_gym.MAX_EPISODE_STEPS
        backend = spec.kwargs["backend"]
        assert (spec.vector_entry_point is not None) == (backend in registration.BATCHED)


def test_the_factory_reads_the_same_table():
    assert factory.BACKENDS is registration.BACKENDS and factory.TASKS is registration.TASKS
    assert factory.DEFAULT_ROBOTS is registration.DEFAULT_ROBOTS


def test_keywords_go_to_the_object_whose_signature_names_them():
    backend_cls, backend_kw, task_cls, task_kw, env_kw = factory.split_kwargs(
        "CCKA",
        "Reach",
        {"num_robots": 1, "distance_threshold": 0.01, "action_mode": "tension"},
    )
    assert backend_cls is AnalyticBackend and task_cls is Reach
    assert backend_kw == {"num_robots": 1}
    assert task_kw == {"distance_threshold": 0.01}
    assert env_kw == {"action_mode": "tension"}


def test_an_unknown_keyword_lists_the_accepted_ones():
    with pytest.raises(ValueError, match=r"unknown keyword argument\(s\) \['gravty'\].*accepted"):
        factory.split_kwargs("CCKA", "Reach", {"gravty": False})


@pytest.mark.parametrize(
    "backend, task, name", [("Mujoco?", "Reach", "backend"), ("CCKA", "Reech", "task")]
)
def test_unknown_backend_or_task_is_named(backend, task, name):
    with pytest.raises(ValueError, match=name):
        factory.split_kwargs(backend, task, {})


def test_the_robot_is_a_preset_or_params_never_both():
    assert factory.resolve_params() == RobotParams()
    assert factory.resolve_params(robot="tdcr2") == RobotParams.preset("tdcr2")
    with pytest.raises(ValueError, match="not both"):
        factory.resolve_params("paper", RobotParams())
    with pytest.raises(ValueError, match="params"):
        factory.resolve_params(params="paper")
    assert factory.default_robot("CCKA", "Pose") == "tdcr2"
    assert factory.default_robot("CCKA", "Reach") == "paper"


def test_make_env_closes_the_backend_when_the_env_refuses_its_arguments():
    with pytest.raises(ValueError, match="initial_state"):
        factory.make_env("CCKA", "Reach", initial_state="bent")


def test_the_env_arguments_are_the_core_options_and_the_rendering_ones():
    """One signature: CDCREnv shows EnvCore's options (and its rendering arguments); the
    factory routes exactly those to the env."""
    import inspect

    from cdcr_gym.envs.core import EnvCore
    from cdcr_gym.envs.env import RENDER_KEYS, CDCREnv

    core = inspect.signature(EnvCore.__init__).parameters
    options = {n for n, p in core.items() if p.kind is p.KEYWORD_ONLY} - {"goal_conditioned"}
    shown = inspect.signature(CDCREnv.__init__).parameters
    assert set(shown) == {"self", "backend", "task"} | options | set(RENDER_KEYS)
    assert set(factory.env_keywords()) == options | set(RENDER_KEYS)
    for name in options:
        assert shown[name].default == core[name].default, name


def test_make_and_make_vec_assemble_the_same_env():
    import gymnasium as gym

    kwargs = dict(robot="tdcr2", action_mode="tension", distance_threshold=0.01)
    single = gym.make("cdcr_gym/CCKAReach-v0", **kwargs).unwrapped
    batched = gym.make_vec(
        "cdcr_gym/CCKAReach-v0", num_envs=2, vectorization_mode="vector_entry_point", **kwargs
    )
    for env in (single, batched):
        assert env.params == RobotParams.preset("tdcr2")
        assert env.action_mode == "tension" and env.task.distance_threshold == 0.01
        assert env.initial_state == "straight" and env.tension_step == 0.05
    assert batched.core.num_envs == 2 and single.core.num_envs == 1
    with pytest.raises(ValueError, match="accepted"):
        gym.make_vec(
            "cdcr_gym/CCKAReach-v0", num_envs=2, vectorization_mode="vector_entry_point", gravty=1
        )
    with pytest.raises(ValueError, match="holds one robot"):
        factory.assemble("Bullet", "Reach", {}, num_robots=2)
