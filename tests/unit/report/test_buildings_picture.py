"""Pictures of an episode among buildings (docs/pictures.md): the layout's city comes with the
episode, the serving links' LoS states are computed from the positions where a file has none,
footprints are drawn shaded by height and links solid (LoS) or dashed (NLoS)."""

from __future__ import annotations

import numpy as np

from adaptsky.drawing.episode_figure import EpisodeFigure
from adaptsky.report.episodes import episode_of
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario

CITY = {"area": {"side_m": 200.0}, "users": {"count": 4, "placement": "uniform"},
        "channel": {"los": "geometric"}, "world": {"buildings": "generated", "city": "urban"}}


def _episode(steps: int = 12):
    scenario = make_scenario(**CITY)
    env = NetworkBatch(scenario, num_envs=1, seed=0)
    env.reset()
    rng = np.random.default_rng(0)
    uav, alpha, rate, los = [], [], [], []
    for _ in range(steps):
        _, _, _, state = env.step(rng.integers(0, env.actions.count, size=1))
        uav.append(env.uav_m[0].copy())
        alpha.append(state.alpha[0])
        rate.append(state.rate_bps[0])
        los.append(state.los[0])
    return scenario, env, np.array(uav), np.array(alpha), np.array(rate), np.array(los)


def test_the_episode_carries_its_city_and_the_links_los_states():
    scenario, env, uav, alpha, rate, los = _episode()
    stored = episode_of(scenario, env.layouts_m[0], uav, alpha, rate, los=los)
    computed = episode_of(scenario, env.layouts_m[0], uav, alpha, rate)  # an eval file's
    assert np.array_equal(computed.los, los) and np.array_equal(stored.los, los)
    assert np.array_equal(stored.buildings_m[:, :4], env.city.footprints_m)
    assert np.array_equal(stored.buildings_m[:, 4], env.city.heights_m[0])


def test_footprints_and_links_by_los_are_drawn():
    scenario, env, uav, alpha, rate, los = _episode()
    episode = episode_of(scenario, env.layouts_m[0], uav, alpha, rate, los=los)
    figure = EpisodeFigure([episode], side_m=scenario.area.side_m)
    figure.show(5)
    block = figure.blocks[0]
    styles = block.serving.get_linestyles()
    assert len(styles) == scenario.num_users
    dashed = [style[1] is not None for style in styles]      # (offset, dashes): None solid
    assert dashed == [not state for state in los[5]]
    top = block.top
    patches = [c for c in top.collections if len(getattr(c, "get_paths", lambda: [])())
               == env.city.count and c is not block.serving]
    assert patches, "the footprints"
    assert figure.save("png")[:4] == b"\x89PNG"


def test_without_buildings_nothing_changes():
    scenario = make_scenario()
    users = np.array(scenario.users.positions_m)
    uav = np.tile([0.0, 0.0, 50.0], (3, 1))
    episode = episode_of(scenario, users, uav, np.full((3, 4), 0.5), np.ones((3, 4)))
    assert episode.buildings_m is None and episode.los is None
    assert EpisodeFigure([episode], side_m=100.0).blocks[0].serving is None
