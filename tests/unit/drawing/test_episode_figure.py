"""The picture of an episode from plain arrays: the data class's checks, the frames of an
animation, what the figure's artists hold (the paths and lines are the trajectory; after frame
k the first k + 1 rows), the optional propulsion-power panel and timed steps, LoS colours,
frames drawn piece by piece against a figure drawn at once."""

from __future__ import annotations

import itertools

import matplotlib
import numpy as np
import pytest

from adaptsky.drawing.episode import (
    EpisodeBuffer,
    EpisodeData,
    default_every,
    frame_steps,
)
from adaptsky.drawing.episode_figure import BLOCK_IN, LOS_CMAP, EpisodeFigure
from tests.helpers.drawing import walk

DPI = 40  # small frames: the tests check numbers, not looks


# ---- the data ---------------------------------------------------------------------------------

def test_one_uav_positions_get_a_uav_axis_and_shapes_are_checked():
    episode = walk(5, 1, 4)
    flat = EpisodeData(episode.users_m, episode.uav_m[:, 0], episode.alpha, episode.rate_bps,
                       episode.serving_uav, episode.cluster)
    assert flat.uav_m.shape == (5, 1, 3) and flat.steps == 5 and flat.num_users == 4
    with pytest.raises(ValueError, match=r"^EpisodeData.alpha: shape \(5, 3\), expected "
                                         r"\(5, 4\) \(T = 5 steps, U = 1 UAVs, N = 4 users\)$"):
        EpisodeData(episode.users_m, episode.uav_m, episode.alpha[:, :3], episode.rate_bps,
                    episode.serving_uav, episode.cluster)
    with pytest.raises(ValueError, match=r"EpisodeData.power_w: shape \(5, 2\), expected"):
        EpisodeData(episode.users_m, episode.uav_m, episode.alpha, episode.rate_bps,
                    episode.serving_uav, episode.cluster, power_w=np.ones((5, 2)))
    with pytest.raises(ValueError, match="serving_uav: UAVs 0 to 0, got 0 to 1"):
        EpisodeData(episode.users_m, episode.uav_m, episode.alpha, episode.rate_bps,
                    np.array([0, 1, 0, 0]), episode.cluster)


def test_pairs_held_and_time():
    episode = walk(4, 2, 8, step_s=0.5)
    assert episode.pairs() == [(0, 0, [0, 2]), (0, 1, [4, 6]), (1, 0, [1, 3]), (1, 1, [5, 7])]
    assert np.array_equal(episode.time, [0.5, 1.0, 1.5, 2.0]) and not episode.held
    held = EpisodeData(episode.users_m, np.repeat(episode.uav_m[:1], 4, axis=0),
                       episode.alpha, episode.rate_bps, episode.serving_uav, episode.cluster)
    assert held.held


@pytest.mark.parametrize(("steps", "every", "frames"), [
    (1000, 5, 200), (1000, 7, 143), (30, 3, 10), (5, 1, 5), (1, 4, 1), (2, 4, 1)])
def test_frames_step_by_every_and_end_at_the_last_step(steps, every, frames):
    rows = frame_steps(steps, every)
    assert len(rows) == frames == -(-steps // every)
    assert rows[0] == min(every, steps) - 1 and rows[-1] == steps - 1
    assert all(0 < b - a <= every for a, b in itertools.pairwise(rows))


def test_a_1000_step_episode_is_200_frames_by_default():
    assert default_every(1000) == 5 and default_every(300) == 2 and default_every(50) == 1


def test_the_buffer_gives_the_rows_recorded_so_far():
    buffer = EpisodeBuffer(capacity=3, num_uavs=1, num_users=2, with_los=True)
    for t in range(3):
        buffer.record(np.array([t, 0.0, 50.0]), np.array([0.5, 0.5]), np.array([1.0, t]),
                      np.array([True, t == 0]))
    episode = buffer.episode(np.zeros((2, 2)), np.zeros(2, int), np.zeros(2, int))
    assert episode.steps == 3 and episode.first_step == 0
    assert np.array_equal(episode.uav_m[:, 0, 0], [0, 1, 2])
    assert np.array_equal(episode.los[:, 1], [True, False, False])
    with pytest.raises(ValueError, match="holds 3 rows"):
        buffer.record(np.zeros(3), np.zeros(2), np.zeros(2))
    buffer.clear()
    assert buffer.rows == 0


# ---- the figure -------------------------------------------------------------------------------

def test_the_whole_picture_draws_the_trajectory():
    episode = walk(40, 2, 8)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    figure.save("png")  # the whole episode: every row in the growing artists
    block = figure.blocks[0]
    assert np.array_equal(block.markers.get_offsets(), episode.uav_m[-1, :, :2])
    for u in range(2):
        assert np.array_equal(block.path(u), episode.uav_m[:, u, :2])
        steps, heights = block.panels[0].line(u)
        assert np.array_equal(steps, np.arange(1, 41))
        assert np.array_equal(heights, episode.uav_m[:, u, 2])
    rates = block.panels[2]
    assert rates.axes.get_ylabel() == "rate $R_i$ (Gbit/s)"
    assert np.allclose(rates.line(5)[1], episode.rate_bps[:, 5] / 1e9)
    # one line per cluster: the share of its first listed user
    shares = block.panels[1]
    legend = [text.get_text() for text in shares.axes.get_legend().get_texts()]
    assert legend[:2] == [r"$\alpha_{1}$ (users 1, 3)", r"$\alpha_{5}$ (users 5, 7)"]
    assert np.array_equal(shares.line(1)[1], episode.alpha[:, 4])
    assert len(block.panels) == 3 and block.step_text.get_text() == "40 steps"
    assert not block.panels[0].cursor.get_visible()


def test_after_frame_k_the_artists_hold_the_first_k_rows():
    episode = walk(30, 1, 4)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    for k in (7, 29, 0):  # also back to an earlier step
        figure.show(k)
        figure.save("png")
        block = figure.blocks[0]
        assert np.array_equal(block.markers.get_offsets()[0], episode.uav_m[k, 0, :2])
        assert np.array_equal(block.panels[0].line(0)[1], episode.uav_m[:k + 1, 0, 2])
        assert np.array_equal(block.panels[2].cursor.get_xdata(), [k + 1, k + 1])
        assert block.step_text.get_text() == f"step {k + 1}/30"
        if k:
            assert np.array_equal(block.path(0), episode.uav_m[:k + 1, 0, :2])


def test_frames_drawn_piece_by_piece_look_like_a_picture_drawn_at_once():
    episode = walk(60, 1, 2)
    animated = EpisodeFigure([episode], side_m=100.0, dpi=50)
    for k in [0, *frame_steps(60, 4)[:-1]]:
        animated.show(k)
        animated.rgb()
    animated.show(59)
    frame = animated.rgb().astype(int)
    at_once = EpisodeFigure([episode], side_m=100.0, dpi=50)
    at_once.show(59)
    whole = at_once.rgb().astype(int)
    assert frame.shape == whole.shape == (250, 550, 3)
    differ = np.abs(frame - whole).sum(axis=-1) > 60
    assert differ.mean() < 0.002  # where pieces join, antialiasing adds up a little


def test_the_frame_size_is_the_figure_size_times_the_dpi():
    figure = EpisodeFigure([walk(5, 1, 4), walk(1, 1, 4, seed=1)], side_m=100.0, dpi=DPI)
    width, height = BLOCK_IN
    assert figure.size_px == (width * DPI, 2 * height * DPI)
    assert figure.rgb().shape == (2 * height * DPI, width * DPI, 3)
    assert figure.blocks[1].step_text.get_text() == "held for 1 step"


def test_propulsion_power_is_a_fourth_panel_only_when_given():
    with_power = walk(20, 2, 4, power=True)
    figure = EpisodeFigure([with_power], side_m=100.0, dpi=DPI)
    figure.save("png")
    panels = figure.blocks[0].panels
    assert len(panels) == 4 and panels[3].axes.get_ylabel() == "propulsion\npower $P$ (W)"
    for u in range(2):
        assert np.array_equal(panels[3].line(u)[1], with_power.power_w[:, u])
    without = EpisodeFigure([walk(20, 2, 4)], side_m=100.0, dpi=DPI)
    assert len(without.blocks[0].panels) == 3
    assert not any("propulsion" in axes.get_ylabel() for axes in without.figure.axes)


def test_timed_steps_put_seconds_on_the_axis():
    episode = walk(10, 1, 4, step_s=0.5, power=True)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    figure.save("png")
    panels = figure.blocks[0].panels
    assert panels[-1].axes.get_xlabel() == "time $t$ (s)"
    assert np.array_equal(panels[-1].line(0)[0], 0.5 * np.arange(1, 11))
    figure.show(3)
    assert figure.blocks[0].step_text.get_text() == "step 4/10, $t$ = 2 s"


def test_users_are_coloured_by_their_los_share_so_far():
    episode = walk(12, 1, 4, los=True)
    figure = EpisodeFigure([episode], side_m=100.0, dpi=DPI)
    figure.show(5)
    expected = matplotlib.colormaps[LOS_CMAP](episode.los[:6].mean(axis=0))
    for collection, members in figure.blocks[0].users:
        assert np.allclose(collection.get_facecolors(), expected[members])
    assert any(axes.get_ylabel() == "LoS share of the steps" for axes in figure.figure.axes)


def test_update_grows_the_episode_and_widens_a_panel_it_leaves():
    buffer = EpisodeBuffer(capacity=6, num_uavs=1, num_users=2, with_los=False)
    users, roles = np.array([[10.0, 0.0], [-10.0, 0.0]]), np.zeros(2, int)
    buffer.record(np.array([0.0, 0.0, 50.0]), np.array([0.5, 0.5]), np.array([1e9, 1e9]))
    figure = EpisodeFigure([buffer.episode(users, roles, roles)], side_m=40.0, dpi=DPI,
                           steps=6)
    assert figure.blocks[0].panels[0].axes.get_xlim() == (0.0, 5.0)
    for t in range(1, 6):
        buffer.record(np.array([t, 0.0, 50.0 + 10 * t]), np.array([0.5, 0.5]),
                      np.array([1e9, 1e9]))
        figure.update([buffer.episode(users, roles, roles)])
        figure.show(t)
        figure.rgb()
    low, high = figure.blocks[0].panels[0].axes.get_ylim()
    assert low <= 50.0 and high >= 100.0  # the height grew out of its first limits
    assert figure.blocks[0].step_text.get_text() == "step 5/5"
    with pytest.raises(ValueError, match="make a new figure"):
        figure.update([buffer.episode(users, roles, np.array([0, 1]))])


def test_clusters_of_three_draw_every_free_share():
    """A cluster of M users draws M - 1 shares where they split its power (the downlink's,
    summing to 1) and all M where they do not (the uplink's transmit shares)."""
    rng = np.random.default_rng(1)
    steps, users = 6, 6
    split = rng.dirichlet([1.0, 1.0, 1.0], size=(steps, 2)).reshape(steps, users)
    common = dict(users_m=rng.uniform(-40, 40, (users, 2)),
                  uav_m=np.tile([0.0, 0.0, 50.0], (steps, 1)),
                  rate_bps=np.full((steps, users), 1e9),
                  serving_uav=np.zeros(users, dtype=int), cluster=np.arange(users) // 3)
    downlink = EpisodeData(alpha=split, **common)
    assert [user for *_, user, _ in downlink.share_lines()] == [0, 1, 3, 4]
    uplink = EpisodeData(alpha=rng.uniform(0.1, 1.0, (steps, users)), **common)
    assert [user for *_, user, _ in uplink.share_lines()] == [0, 1, 2, 3, 4, 5]
    figure = EpisodeFigure([downlink], side_m=100.0, dpi=DPI)
    shares = figure.blocks[0].columns()[1]
    np.testing.assert_array_equal(shares, split[:, [0, 1, 3, 4]])
