"""Episodes of users that move (``users.speed_m_per_step > 0``) from a rollout's trace, a run
file and an eval file: the users' track is every step's positions of the layout drawn, the
same in ``show RUN.h5`` as in ``eval RUN.h5``'s file, and ``show`` draws the users away from
their start; standing users give no track."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.drawing.episode_figure import EpisodeFigure
from adaptsky.evaluation.api import eval_layouts
from adaptsky.evaluation.show import run_episode
from adaptsky.report.episodes import eval_episodes, trace_episode
from adaptsky.rollouts.rollout import rollout
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS, make_scenario

SPEED = 3.0
STEPS = 8
DPI = 40


def _stay(obs: np.ndarray) -> np.ndarray:
    return np.zeros(len(obs), dtype=np.int64)


@pytest.fixture(scope="module")
def walking_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny run of the paper's network with users walking 3 m a step."""
    path = tmp_path_factory.mktemp("walking") / "run.h5"
    assert main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--seeds", "0", "--episodes",
                 "2", "--steps", "5", "--workers", "1", "--quiet", "--set",
                 f"users.speed_m_per_step={SPEED}", "--out", str(path)]) == 0
    return path


def test_a_trace_s_user_positions_become_the_layout_s_track():
    scenario = make_scenario(users={"speed_m_per_step": SPEED})
    layouts = np.stack([eval_layouts(scenario, None)[0]] * 2)
    layouts[1] *= 0.5   # another layout, well inside the area
    trace = rollout(scenario, _stay, STEPS, layouts)
    assert trace.users_m is not None and trace.users_m.shape == (STEPS, 2, 4, 2)
    episode = trace_episode(scenario, trace, layouts, layout=1)
    assert np.array_equal(episode.users_m, layouts[1])
    assert np.array_equal(episode.user_track_m, trace.users_m[:, 1])
    # row 0 is the state after step 1: each user one step from where it started
    steps = np.linalg.norm(episode.user_track_m[0] - layouts[1], axis=-1)
    assert np.allclose(steps, SPEED)
    standing = make_scenario()
    still = trace_episode(standing, rollout(standing, _stay, 3, layouts), layouts)
    assert still.user_track_m is None


def test_show_of_a_run_draws_users_where_eval_stores_them(walking_run, tmp_path, capsys):
    scenario, episode, _ = run_episode(walking_run, steps=STEPS)
    assert scenario.users.speed_m_per_step == SPEED
    assert episode.user_track_m.shape == (STEPS, 4, 2)
    moved = np.linalg.norm(episode.user_track_m[-1] - episode.users_m, axis=-1)
    assert np.all(moved > 0)   # every user walked off its start
    stored = tmp_path / "eval.h5"
    assert main(["eval", str(walking_run), "--steps", str(STEPS), "--compare", "soa",
                 "--out", str(stored), "--json"]) == 0
    with h5py.File(stored, "r") as file:
        users_m = file["methods/policy/trajectory/users_m"][:, 0]
    assert np.array_equal(episode.user_track_m, users_m)   # the rollout eval stores
    _, (policy, soa) = eval_episodes(stored)
    assert np.array_equal(policy.user_track_m, users_m)
    assert soa.held and soa.users_move   # SoA holds its configuration; its users walk
    assert np.array_equal(soa.users_m, policy.users_m)
    figure = EpisodeFigure([policy, soa], side_m=scenario.area.side_m, dpi=DPI)
    figure.save("png")
    for block in figure.blocks:
        shown = np.concatenate([collection.get_offsets() for collection, _ in block.users])
        members = np.concatenate([m for _, m in block.users])
        assert np.array_equal(shown, block.episode.user_track_m[-1][members])
    for source, name in ((walking_run, "run.png"), (stored, "eval.png")):
        assert main(["show", str(source), "--out", str(tmp_path / name), "--steps",
                     str(STEPS), "--dpi", str(DPI), "--quiet"]) == 0
        assert (tmp_path / name).stat().st_size > 0
    capsys.readouterr()
