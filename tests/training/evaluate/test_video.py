"""training.video: MP4 people can play (H.264, yuv420p, even sizes), GIF when asked."""

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
