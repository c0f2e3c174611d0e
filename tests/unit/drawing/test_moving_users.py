"""Users that move (``users.speed_m_per_step > 0``): the episode's user track (its checks and
slices), the figure's users at the track's row shown, their tracks in their cluster's colour
from a faint start, serving links from where the users are, frames drawn piece by piece
against a picture drawn at once, the buffer's track and the Gymnasium env's frames; users
that stand draw no track."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from adaptsky.drawing.episode import EpisodeBuffer, EpisodeData
from adaptsky.drawing.episode_figure import EpisodeFigure, cluster_colours
from adaptsky.envs.gym_env import NomaUavEnv
from tests.conftest import make_scenario
from tests.helpers.drawing import walk

DPI = 40


def walking(steps: int, uavs: int, users: int, *, seed: int = 0, speed: float = 3.0,
            **extra: object) -> EpisodeData:
    """:func:`walk` with users on a random walk of ``speed`` m a step from their layout."""
    episode = walk(steps, uavs, users, seed=seed, **extra)
    rng = np.random.default_rng(seed + 100)
    headings = rng.uniform(0, 2 * np.pi, (steps, users))
    moves = speed * np.stack([np.cos(headings), np.sin(headings)], axis=-1)
    track = episode.users_m + np.cumsum(moves, axis=0)               # (T, N, 2)
    return EpisodeData(episode.users_m, episode.uav_m, episode.alpha, episode.rate_bps,
                       episode.serving_uav, episode.cluster, los=episode.los,
                       power_w=episode.power_w, step_s=episode.step_s, user_track_m=track)


def _user_offsets(figure: EpisodeFigure, block: int = 0) -> np.ndarray:
    """Every user's marker position (N, 2) as the figure's scatters hold them."""
    blocks = figure.blocks[block]
    found = np.full((blocks.episode.num_users, 2), np.nan)
    for collection, members in blocks.users:
        found[members] = collection.get_offsets()
    return found


# ---- the data ---------------------------------------------------------------------------------

def test_a_track_is_checked_sliced_and_gives_each_row_s_positions():
    episode = walking(6, 1, 4)
    assert episode.users_move and episode.user_track_m.shape == (6, 4, 2)
    assert np.array_equal(episode.users_at(2), episode.user_track_m[2])
    short = episode.until(3)
    assert short.user_track_m.shape == (3, 4, 2) and short.steps == 3
    assert np.array_equal(short.user_track_m, episode.user_track_m[:3])
    assert np.array_equal(short.users_m, episode.users_m)   # the start stays
    with pytest.raises(ValueError, match=r"^EpisodeData.user_track_m: shape \(5, 4, 2\), "
                                         r"expected \(6, 4, 2\) \(T = 6 steps"):
        EpisodeData(episode.users_m, episode.uav_m, episode.alpha, episode.rate_bps,
                    episode.serving_uav, episode.cluster,
                    user_track_m=episode.user_track_m[:5])
    standing = walk(6, 1, 4)
    assert not standing.users_move and standing.until(2).user_track_m is None
    assert np.array_equal(standing.users_at(4), standing.users_m)


# ---- the figure -------------------------------------------------------------------------------

def test_the_whole_picture_puts_the_users_at_the_last_row_and_draws_their_tracks():
    episode = walking(30, 1, 4)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    figure.save("png")
    block = figure.blocks[0]
    last = episode.user_track_m[-1]
    assert np.array_equal(_user_offsets(figure), last)
    assert not np.allclose(last, episode.users_m)   # they walked away from the start
    assert [label.xy for label in block.user_labels] == [tuple(p) for p in last]
    starts = np.full((4, 2), np.nan)
    for collection, members in block.starts:
        starts[members] = collection.get_offsets()
    assert np.array_equal(starts, episode.users_m)   # the start, faint
    for i in range(4):  # the start, then every row
        assert np.array_equal(block.track(i), np.concatenate([episode.users_m[i:i + 1],
                                                              episode.user_track_m[:, i]]))
    # each user's track in its cluster's colour (the power-split panel's line)
    colours = cluster_colours(episode)
    segments = len(block.tracks.get_segments()) // 4
    for i in range(4):
        expected = to_rgba(colours[episode.serving_uav[i], episode.cluster[i]], 0.8)
        assert np.allclose(block.tracks.get_colors()[i * segments], expected)
    legend = [text.get_text() for text in block.top.get_legend().get_texts()]
    assert legend[-2:] == ["user start", "user track"]


def test_a_frame_at_row_r_puts_the_users_at_the_track_s_row_r():
    episode = walking(25, 1, 4)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    for row in (4, 17, 24, 2):   # also back to an earlier step
        figure.show(row)
        figure.rgb()
        assert np.array_equal(_user_offsets(figure), episode.user_track_m[row])
        labels = figure.blocks[0].user_labels
        assert np.allclose([label.xy for label in labels], episode.user_track_m[row])
    figure.show(9)
    figure.save("png")  # the tracks up to the row shown
    assert np.array_equal(figure.blocks[0].track(3),
                          np.concatenate([episode.users_m[3:4], episode.user_track_m[:10, 3]]))


def test_serving_links_leave_from_where_the_users_are():
    episode = walking(12, 2, 8)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    figure.show(6)
    links = np.asarray(figure.blocks[0].serving.get_segments())   # (N, 2, 2)
    assert np.array_equal(links[:, 0], episode.user_track_m[6])
    assert np.array_equal(links[:, 1], episode.uav_m[6, episode.serving_uav, :2])


def test_frames_with_moving_users_look_like_a_picture_drawn_at_once():
    """Users are drawn per frame (no ghost where they were), tracks piece by piece."""
    episode = walking(60, 2, 4, speed=2.0, los=True)
    animated = EpisodeFigure([episode], side_m=100.0, dpi=50)
    for k in [0, *range(3, 59, 4)]:
        animated.show(k)
        animated.rgb()
    animated.show(59)
    frame = animated.rgb().astype(int)
    at_once = EpisodeFigure([episode], side_m=100.0, dpi=50)
    at_once.show(59)
    whole = at_once.rgb().astype(int)
    differ = np.abs(frame - whole).sum(axis=-1) > 60
    assert differ.mean() < 0.002
    # and a frame at the start differs from one at the end where the users went
    at_once.show(0)
    start = at_once.rgb().astype(int)
    assert (np.abs(start - whole).sum(axis=-1) > 60).mean() > 0.002


def test_users_that_stand_draw_no_track_and_stay_in_the_background():
    episode = walk(10, 1, 4)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    block = figure.blocks[0]
    assert block.tracks is None and block.starts == []
    assert not any(collection in block.moving for collection, _ in block.users)
    figure.show(5)
    assert np.array_equal(_user_offsets(figure), episode.users_m)
    legend = [text.get_text() for text in block.top.get_legend().get_texts()]
    assert "user track" not in legend and "user start" not in legend


# ---- the buffer and the env -------------------------------------------------------------------

def _record(buffer: EpisodeBuffer, users_m: np.ndarray) -> None:
    buffer.record(np.array([0.0, 0.0, 50.0]), np.array([0.5, 0.5]), np.array([1e9, 1e9]),
                  users_m=users_m)


def test_the_buffer_tracks_users_once_they_move():
    roles = np.zeros(2, int)
    buffer = EpisodeBuffer(capacity=4, num_uavs=1, num_users=2, with_los=False)
    layout = np.array([[10.0, 0.0], [-10.0, 0.0]])
    for _ in range(3):
        _record(buffer, layout)
    now = np.array([[1.0, 1.0], [2.0, 2.0]])
    assert buffer.episode(now, roles, roles).user_track_m is None   # standing users
    _record(buffer, layout + np.array([[3.0, 0.0], [0.0, -3.0]]))
    episode = buffer.episode(now, roles, roles)
    assert episode.user_track_m.shape == (4, 2, 2)
    assert np.array_equal(episode.users_m, layout)   # the start: the first row's
    assert np.array_equal(episode.user_track_m[-1], [[13.0, 0.0], [-10.0, -3.0]])
    buffer.clear()
    _record(buffer, layout)
    again = buffer.episode(layout, roles, roles)   # a new episode keeps its track (fits)
    assert again.user_track_m.shape == (1, 2, 2) and EpisodeFigure.fits(episode, again)


def test_the_env_s_frames_show_users_where_they_walked():
    scenario = make_scenario(train={"steps": 8}, users={"speed_m_per_step": 4.0})
    env = NomaUavEnv(scenario, render_mode="rgb_array")
    env.reset(seed=0)
    start = env.batch.users_m[0].copy()
    env.render()
    for action in (0, 5, 31, 2, 7):
        env.step(action)
        env.render()
    picture = env._picture
    now = env.batch.users_m[0]
    assert not np.allclose(now, start)
    assert np.array_equal(_user_offsets(picture), now)
    block = picture.blocks[0]
    assert np.array_equal(block.episode.users_m, start)
    picture.save("png")
    assert np.array_equal(block.track(0)[[0, -1]], [start[0], now[0]])
    env.reset(seed=1)   # the next episode in the same figure
    env.render()
    assert env._picture is picture
    assert np.array_equal(_user_offsets(picture), env.batch.users_m[0])
