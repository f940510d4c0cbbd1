"""training.evaluate.video: MP4 people can play (H.264, yuv420p, even sizes), GIF when asked."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("imageio_ffmpeg", reason="the [video] extra")

from training.evaluate.video import even_frame, probe_video, write_video  # noqa: E402


def _frames(n, h, w):
    rng = np.random.default_rng(0)
    base = rng.integers(0, 255, (h, w, 3), dtype=np.uint8)
    return [np.roll(base, i, axis=1) for i in range(n)]


@pytest.mark.parametrize(("h", "w"), [(64, 96), (33, 47)])
def test_mp4_is_h264_yuv420p_with_all_frames_and_even_size(tmp_path, h, w):
    path = write_video(tmp_path / "sub" / "episodes.mp4", iter(_frames(37, h, w)), fps=25)
    info = probe_video(path)
    assert info.codec == "h264"
    assert info.pix_fmt == "yuv420p"
    assert (info.height, info.width) == (h + h % 2, w + w % 2)
    assert info.n_frames == 37
    assert info.fps == pytest.approx(25.0)


def test_gif_only_when_asked(tmp_path):
    path = write_video(tmp_path / "episodes.gif", _frames(5, 32, 32), fps=10)
    info = probe_video(path)
    assert info.codec == "gif" and info.n_frames == 5 and (info.width, info.height) == (32, 32)


def test_rendered_frames_make_a_video(tmp_path):
    from cdcr_gym import rendering
    from cdcr_gym.model.params import RobotParams

    scene = rendering._demo_scene(RobotParams())
    frames = (rendering.draw_scene(width=161, height=121, **scene) for _ in range(10))
    info = probe_video(write_video(tmp_path / "robot.mp4", frames))
    assert (info.codec, info.width, info.height, info.n_frames) == ("h264", 162, 122, 10)


def test_bad_input_raises(tmp_path):
    with pytest.raises(ValueError, match="mp4 or .gif"):
        write_video(tmp_path / "x.avi", _frames(2, 16, 16))
    with pytest.raises(ValueError, match="no frames"):
        write_video(tmp_path / "x.mp4", [])
    with pytest.raises(ValueError, match="frame 1"):
        write_video(
            tmp_path / "x.mp4", [np.zeros((16, 16, 3), np.uint8), np.zeros((8, 16, 3), np.uint8)]
        )
    assert not (tmp_path / "x.mp4").exists()
    with pytest.raises(ValueError, match="fps"):
        write_video(tmp_path / "x.mp4", _frames(2, 16, 16), fps=0)
    assert even_frame(np.zeros((3, 5, 3), np.uint8)).shape == (4, 6, 3)


@pytest.mark.parametrize("env_id", ["cdcr_gym/CCKAReach-v0", "cdcr_gym/BulletReach-v0"])
def test_gymnasium_record_video_wrapper_works_on_every_id(env_id, tmp_path):
    import gymnasium as gym
    from gymnasium.wrappers import RecordVideo

    import cdcr_gym  # noqa: F401

    env = gym.make(env_id, render_mode="rgb_array", render_width=96, render_height=96)
    env = RecordVideo(env, str(tmp_path), episode_trigger=lambda e: True, name_prefix="ep")
    env.reset(seed=0)
    for _ in range(12):
        env.step(env.action_space.sample())
    env.close()
    (video,) = tmp_path.glob("ep-episode-0.mp4")
    info = probe_video(video)
    assert (info.width, info.height) == (96, 96) and info.n_frames >= 12


def test_frames_carry_the_step_the_tip_error_and_the_task_metric():
    """Issue 23.9: evaluation videos had no text; each frame now says the step, the tip error
    (mm) and the task's metric, drawn with a built-in bitmap font."""
    from training.evaluate.overlay import caption, draw_text, text_mask

    info = {"distance": 0.01234, "is_success": False, "angle": np.radians(12.0)}
    assert caption(7, 100, info, "Pose") == [
        "step 7/100",
        "tip error 12.3 mm",
        "angle error 12.0°",
        "not yet",
    ]
    assert caption(3, 50, {"distance": 0.002, "tracking_rms": 0.0015}, "Track")[2] == (
        "tracking rms 1.5 mm"
    )
    assert caption(1, 9, {"min_clearance": 0.02, "collided": True}, "Obstacle")[1] == (
        "clearance 20.0 mm collided"
    )
    assert not np.array_equal(text_mask("step 1"), text_mask("step 2"))
    frame = np.full((120, 160, 3), 90, dtype=np.uint8)
    out = draw_text(frame, ["step 1/100", "tip error 3.2 mm"])
    assert out.shape == frame.shape and out.dtype == np.uint8
    assert (out[:40, :100] == 255).any() and (out[60:] == frame[60:]).all()
    assert (frame == 90).all()  # the input is not modified


def test_the_evaluation_video_has_text_on_every_frame(monkeypatch, tmp_path):
    from training.evaluate import agent
    from training.run.rollout import EpisodeSpecs

    written = {}

    def capture(path, frames, fps=25.0):
        written["frames"] = list(frames)
        return path

    monkeypatch.setattr(agent, "write_video", capture)
    specs = EpisodeSpecs.from_seeds(1, 0)
    agent._write_video(
        "cdcr_gym/CCKAReach-v0", {}, lambda obs: np.zeros((len(obs), 3)), specs, 4, 1, tmp_path, 4
    )
    import gymnasium as gym

    env = gym.make(
        "cdcr_gym/CCKAReach-v0", render_mode="rgb_array", render_width=320, render_height=320
    )
    env.reset(**specs.reset_kwargs(0))
    plain = env.render()
    env.close()
    first = written["frames"][0]
    assert first.shape == plain.shape and not np.array_equal(first[:60], plain[:60])
    assert all((f[:40, :200] == 255).any() for f in written["frames"])
