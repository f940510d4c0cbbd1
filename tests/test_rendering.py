"""The numpy renderer: image format, markers where they project, tension colours, human mode."""

from __future__ import annotations

import time

import numpy as np
import pytest

from cdcr_gym import rendering
from cdcr_gym.model.params import RobotParams
from cdcr_gym.rendering import GOAL_COLOUR, Camera, draw_scene, show_scene


@pytest.fixture(params=["paper", "tdcr2"])
def params(request):
    return RobotParams.preset(request.param)


def _scene(params, **overrides):
    scene = rendering._demo_scene(params)
    scene.update(overrides)
    return scene


@pytest.mark.parametrize("size", [(480, 480), (97, 64)])
def test_image_shape_and_dtype(params, size):
    width, height = size
    image = draw_scene(width=width, height=height, **_scene(params))
    assert image.shape == (height, width, 3) and image.dtype == np.uint8
    assert image.std() > 5  # not blank


def test_the_goal_marker_is_drawn_where_the_goal_projects(params):
    goal = np.array([0.3, -0.2, 0.6]) * params.length  # away from the robot
    image = draw_scene(width=320, height=240, **_scene(params, goal=goal))
    without = draw_scene(width=320, height=240, **_scene(params, goal=None))
    u, v, _ = Camera.fixed(params.length, 320, 240).project(goal)
    y, x = int(v), int(u)
    pixel = image[y, x].astype(int)
    assert np.any(pixel != without[y, x])
    # purple: red and blue well above green, in the goal colour's proportions up to shading
    r, g, b = pixel
    assert b > g + 60 and r > g + 30, pixel
    hue = np.asarray(GOAL_COLOUR) / np.linalg.norm(GOAL_COLOUR)
    assert float(pixel @ hue) / np.linalg.norm(pixel) > 0.97


def test_more_tension_makes_the_cable_redder(params):
    slack = np.zeros(params.n_cables)
    pulled = slack.copy()
    pulled[-1] = params.max_tension  # a distal cable: drawn along the whole robot
    a = draw_scene(width=320, height=320, **_scene(params, tensions=slack))
    b = draw_scene(width=320, height=320, **_scene(params, tensions=pulled))
    changed = np.any(a != b, axis=-1)
    assert changed.sum() > 50
    redness = lambda img: (img[changed, 0].astype(int) - img[changed, 2].astype(int)).mean()  # noqa: E731
    assert redness(b) > redness(a) + 50
    np.testing.assert_array_equal(rendering.tension_colour(1.0), rendering.tension_colour(2.0))
    assert not np.array_equal(rendering.tension_colour(0.0), rendering.tension_colour(1.0))


def test_obstacles_and_target_are_drawn(params):
    scene = _scene(params)
    plain = draw_scene(width=160, height=160, **scene)
    sphere = [(np.array([0.3, 0.0, 0.3]) * params.length, 0.1 * params.length)]
    with_obstacle = draw_scene(width=160, height=160, obstacles=sphere, **scene)
    assert np.any(with_obstacle != plain)
    as_rows = draw_scene(
        width=160, height=160, **scene, obstacles=np.array([[0.3, 0.0, 0.3, 0.1]]) * params.length
    )
    np.testing.assert_array_equal(as_rows, with_obstacle)
    with_target = draw_scene(
        width=160,
        height=160,
        target=np.array([0, 0, 0.5]) * params.length,
        **{k: v for k, v in scene.items()},
    )
    assert np.any(with_target != plain)


def test_bad_inputs_raise_value_errors_naming_the_argument():
    params = RobotParams()
    scene = _scene(params)
    with pytest.raises(ValueError, match="disk_centres"):
        draw_scene(**{**scene, "disk_centres": scene["disk_centres"][:-1]})
    with pytest.raises(ValueError, match="tensions"):
        draw_scene(**{**scene, "tensions": np.zeros(params.n_cables + 1)})
    with pytest.raises(ValueError, match="goal"):
        draw_scene(**{**scene, "goal": np.array([np.nan, 0.0, 0.0])})
    with pytest.raises(ValueError, match="width"):
        draw_scene(width=0, **scene)
    with pytest.raises(ValueError, match="obstacles"):
        draw_scene(obstacles=[(np.zeros(3), -1.0)], **scene)


def test_no_display_raises_a_runtime_error(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(rendering.sys, "platform", "linux")
    with pytest.raises(RuntimeError, match="display"):
        show_scene(**_scene(RobotParams()))


def test_a_non_interactive_matplotlib_backend_raises_a_runtime_error(monkeypatch):
    matplotlib = pytest.importorskip("matplotlib")
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(matplotlib, "get_backend", lambda: "agg")
    with pytest.raises(RuntimeError, match="interactive"):
        show_scene(**_scene(RobotParams()))
    rendering.close_window()  # nothing open: a no-op


def test_rendering_is_fast():
    """Old matplotlib renderer: ~12 frames/s at 320x320; this one is ~10x faster."""
    scene = _scene(RobotParams())
    draw_scene(width=320, height=320, **scene)
    start = time.perf_counter()
    for _ in range(50):
        draw_scene(width=320, height=320, **scene)
    fps = 50 / (time.perf_counter() - start)
    assert fps > 25, f"{fps:.0f} frames/s"


@pytest.mark.parametrize("env_id", ["cdcr_gym/CCKAReach-v0", "cdcr_gym/BulletReach-v0"])
def test_every_backend_renders_through_the_env(env_id):
    import gymnasium as gym

    import cdcr_gym  # noqa: F401

    env = gym.make(env_id, render_mode="rgb_array", render_width=128, render_height=96)
    try:
        env.reset(seed=0)
        env.step(env.action_space.sample())
        frame = env.render()
    finally:
        env.close()
    assert frame.shape == (96, 128, 3) and frame.dtype == np.uint8
    assert frame.std() > 5
