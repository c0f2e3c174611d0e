"""``render_mode="rgb_array"``: frames of the episode so far from the picture of ``adaptsky
show`` (one figure, its artists moved), for one UAV and several, check_env with it, the
PettingZoo env's frames, and Gymnasium's RecordVideo writing a video of an episode."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import adaptsky  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky.drawing.episode_figure import BLOCK_IN, DPI
from adaptsky.envs.gym_env import RENDER_FPS, NomaUavEnv
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from tests.conftest import SUB6_RADIO, make_scenario
from tests.unit.envs.several_uavs import two_uavs

ENV_ID = "adaptsky/NomaUav-v0"
FRAME = (int(BLOCK_IN[1] * DPI), int(BLOCK_IN[0] * DPI), 3)


def test_rgb_array_frames_show_the_episode_so_far():
    env = NomaUavEnv(make_scenario(train={"steps": 6}), render_mode="rgb_array")
    assert "rgb_array" in env.metadata["render_modes"] and env.metadata["render_fps"] > 0
    with pytest.raises(RuntimeError, match="reset"):
        env.render()
    _, info = env.reset(seed=0)
    first = env.render()
    assert first.shape == FRAME and first.dtype == np.uint8
    positions = [info["uav_m"]]
    for action in (0, 31, 5):
        _, _, _, _, info = env.step(action)
        positions.append(info["uav_m"])
        frame = env.render()
    assert frame.shape == FRAME and not np.array_equal(frame, first)
    picture = env._picture
    block = picture.blocks[0]
    assert np.array_equal(block.markers.get_offsets()[0], positions[-1][:2])
    assert block.step_text.get_text() == "step 3/6"
    picture.save("png")  # every row in the artists: the path so far, from step 0
    assert np.array_equal(block.path(0), np.array(positions)[:, :2])
    assert np.array_equal(block.panels[0].line(0)[1], np.array(positions)[:, 2])
    env.reset(seed=1)  # a new episode in the same figure
    assert env.render().shape == FRAME and env._picture is picture
    assert block.step_text.get_text() == "step 0/6"


def test_rgb_array_with_several_uavs_and_sampled_los():
    env = NomaUavEnv(two_uavs(steps=4, moving=True), render_mode="rgb_array")
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(2):
        _, _, _, _, info = env.step(env.action_space.sample())
    assert env.render().shape == FRAME
    block = env._picture.blocks[0]
    assert np.array_equal(block.markers.get_offsets(), info["uav_m"][:, :2])
    assert block.episode.los is not None and block.serving is not None  # LoS drawn, 2 UAVs


def test_check_env_renders_rgb_array_quietly():
    scenario = make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani",
                                                        "los": "sampled"}, train={"steps": 5})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gymnasium.make(ENV_ID, scenario=scenario, render_mode="rgb_array").unwrapped)


def test_the_parallel_env_renders_frames_too():
    env = NomaUavParallelEnv(two_uavs(steps=3), render_mode="rgb_array")
    assert "rgb_array" in env.metadata["render_modes"]
    env.reset(seed=0)
    env.step({agent: env.action_space(agent).sample() for agent in env.agents})
    assert env.render().shape == FRAME


def test_record_video_writes_an_episode(tmp_path: Path):
    pytest.importorskip("moviepy", reason="Gymnasium's RecordVideo writes videos with moviepy "
                                          "(pip install moviepy)")
    from gymnasium.wrappers import RecordVideo

    env = gymnasium.make(ENV_ID, scenario=make_scenario(train={"steps": 4}),
                         render_mode="rgb_array")
    env = RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda episode: True,
                      disable_logger=True)
    env.reset(seed=0)
    truncated = False
    while not truncated:
        _, _, _, truncated, _ = env.step(env.action_space.sample())
    env.close()
    videos = sorted((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
    import imageio_ffmpeg  # moviepy's own dependency

    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(videos[0]))
    assert frames == 5 and seconds == pytest.approx(5 / RENDER_FPS, abs=0.1)  # reset + 4 steps
