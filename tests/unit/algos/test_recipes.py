"""Agent recipes and their extensions: presets, reward scaling, n-step returns, soft target
updates, a decaying learning rate, and users placed afresh every training episode. Numbers
are checked against formulas written out here; resumed runs against uninterrupted ones."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from adaptsky.algos.dqn.stacked import StackedDqn
from adaptsky.algos.returns import NStepWindow
from adaptsky.algos.shared.checkpoint import replay_rows
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.layout import episode_layouts
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import make_scenario

OBS = 17  # 4 users: 4 features each and the height
# a coarse UAV lattice (11 x 11 x 20 points): the oracle of an evaluation costs nothing
FAST_UAV = {"step_m": [10.0, 10.0, 10.0]}
SMALL_AGENT = {"hidden_sizes": [16, 16], "batch_size": 8, "memory_size": 200,
               "target_update_episodes": 2}


def scenario(agent: dict | None = None, users: dict | None = None, **sections):
    """A small, fast scenario: 20 steps per episode, no greedy evaluations unless asked."""
    train = {"steps": 20, "episodes": 4, "checkpoint_every": 2, "eval_every": 0,
             **sections.pop("train", {})}
    extra = {"users": users} if users is not None else {}
    return make_scenario(uav=FAST_UAV, agent={**SMALL_AGENT, **(agent or {})}, train=train,
                         **extra, **sections)


def write(tmp_path: Path, name: str, **kwargs) -> Path:
    path = tmp_path / f"{name}.toml"
    data = scenario(**kwargs).model_dump(mode="json")
    data["name"] = name
    path.write_text(dumps(data))
    return path


def assert_same_tree(a, b, where: str = "") -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for key in a:
            assert_same_tree(a[key], b[key], f"{where}/{key}")
    elif isinstance(a, np.ndarray) and a.dtype.kind == "f":
        assert np.array_equal(a, b, equal_nan=True), where
    else:
        assert np.array_equal(np.asarray(a), np.asarray(b)), where


def stored(path: Path) -> tuple[dict, dict]:
    """Seed 0's learning curves and its checkpoint's agent, replay and generator states."""
    with RunReader(path) as run:
        checkpoint = run.checkpoint(0)
        return run.episodes(0), {key: checkpoint[key] for key in ("agent", "replay", "rng",
                                                                   "episode")}


# ---- presets ------------------------------------------------------------------------------

def test_paper_preset_is_every_default():
    paper = make_scenario(agent={"preset": "paper"}).agent
    assert paper == make_scenario().agent
    assert (paper.gamma, paper.lr, paper.loss, paper.double_dqn) == (0.999, 1e-3, "mse", False)
    assert (paper.reward_scale, paper.n_step, paper.target_tau, paper.lr_end) == (1.0, 1, 0.0,
                                                                                  None)


def test_tuned_preset_fills_the_keys_not_given_and_given_keys_win():
    tuned = make_scenario(agent={"preset": "tuned"}).agent
    assert tuned.double_dqn is True and tuned.user_order == "clusters"
    assert (tuned.epsilon_end, tuned.epsilon_decay_steps) == (0.01, 30_000.0)
    assert (tuned.lr_end, tuned.lr_decay_steps) == (1e-4, 300_000.0)
    # not in the recipe: the paper's
    assert (tuned.lr, tuned.gamma, tuned.loss, tuned.reward_scale) == (1e-3, 0.999, "mse", 1.0)
    assert (tuned.target_tau, tuned.n_step, tuned.hidden_sizes) == (0.0, 1, [128, 128])
    mine = make_scenario(agent={"preset": "tuned", "gamma": 0.5, "double_dqn": False,
                                "target_tau": 0.01}).agent
    assert (mine.gamma, mine.double_dqn, mine.target_tau) == (0.5, False, 0.01)
    assert mine.epsilon_end == 0.01 and mine.user_order == "clusters"
    # the resolved agent (as a run file's config stores it) reads back as itself
    again = make_scenario(agent=mine.model_dump(mode="json")).agent
    assert again == mine


def test_unknown_preset_is_one_line_naming_the_presets(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n[agent]\npreset = "fast"\n')
    assert main(["scenario", "validate", str(path)]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"{path}: agent: unknown preset 'fast'; choose from paper, tuned"]


def test_scenario_show_prints_what_a_preset_resolves_to(tmp_path, capsys):
    path = tmp_path / "tuned.toml"
    path.write_text('name = "x"\n[agent]\npreset = "tuned"\nlr_end = 5e-5\n')
    assert main(["scenario", "show", str(path)]) == 0
    out = capsys.readouterr().out
    assert 'preset = "tuned"' in out and "epsilon_end = 0.01" in out
    assert "lr_end = 5e-5" in out and 'user_order = "clusters"' in out


@pytest.mark.parametrize("algorithm, family", [("ppo", "ppo"), ("sac", "sac"),
                                                ("mappo", "mappo"), ("ippo", "mappo")])
def test_learners_presets_cleanrl_is_every_default_and_tuned_fills_the_rest(algorithm, family):
    from adaptsky.scenario.presets import PRESETS

    agents = {preset: make_scenario(agent={"algorithm": algorithm, "preset": preset}).agent
              for preset in ("cleanrl", "tuned")}
    plain = make_scenario(agent={"algorithm": algorithm}).agent
    assert plain.preset == "cleanrl" and agents["cleanrl"] == plain
    tuned = agents["tuned"].model_dump()
    recipe = PRESETS[family]["tuned"]
    assert recipe, f"{family}'s tuned preset sets no key"
    expected = {**plain.model_dump(), **recipe, "preset": "tuned"}
    assert tuned == expected
    # a key given in the file wins over the recipe, and the resolved table reads back
    key = next(iter(recipe))
    mine = make_scenario(agent={"algorithm": algorithm, "preset": "tuned",
                                key: getattr(plain, key)}).agent
    assert getattr(mine, key) == getattr(plain, key)
    assert make_scenario(agent=mine.model_dump(mode="json")).agent == mine


def test_a_learners_unknown_preset_names_its_own_presets(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n[agent]\nalgorithm = "ppo"\npreset = "paper"\n')
    assert main(["scenario", "validate", str(path)]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"{path}: agent: unknown preset 'paper'; choose from cleanrl, tuned"]


# ---- reward scale --------------------------------------------------------------------------

def test_rewards_are_scaled_before_they_are_stored_but_not_in_the_curves():
    # batch 64 > 20 steps: no update in the first episode, so both runs act alike
    runs = {scale: StackRun([Member(scenario(agent={"reward_scale": scale, "batch_size": 64}),
                                    3)]) for scale in (1.0, 0.01)}
    results = {scale: run.run_episode()[0] for scale, run in runs.items()}
    reward = results[1.0].trajectory["reward"]
    assert np.array_equal(results[0.01].trajectory["reward"], reward)
    assert results[0.01].metrics["reward"] == pytest.approx(reward.sum(), rel=1e-12)
    for scale, run in runs.items():
        rows = run.algorithm.memory.arrays(0)["rewards"]
        assert len(rows) == 20
        assert np.allclose(rows, (reward * scale).astype(np.float32), rtol=1e-6, atol=0)
    assert abs(reward).max() > 0


# ---- n-step returns ------------------------------------------------------------------------

def _step(value: float) -> tuple[np.ndarray, ...]:
    """One step of one member, every array marked with ``value``."""
    return (np.full((1, OBS), value, np.float32), np.array([int(value)]),
            np.array([value]), np.full((1, OBS), value + 0.5, np.float32))


def test_n_step_window_by_hand():
    window = NStepWindow(3, 0.5)
    steps = [_step(v) for v in (1.0, 2.0, 4.0, 8.0)]
    assert window.push(*steps[0]) is None
    assert window.push(*steps[1]) is None
    obs, action, ret, next_obs = window.push(*steps[2])
    assert obs[0, 0] == 1.0 and action[0] == 1
    assert ret[0] == pytest.approx(1 + 0.5 * 2 + 0.25 * 4)          # 3
    assert next_obs[0, 0] == 4.5                                     # s' of the third step
    obs, action, ret, next_obs = window.push(*steps[3])
    assert obs[0, 0] == 2.0 and action[0] == 2
    assert ret[0] == pytest.approx(2 + 0.5 * 4 + 0.25 * 8)          # 6
    assert next_obs[0, 0] == 8.5
    window.restart()
    assert window.push(*steps[0]) is None and window.push(*steps[1]) is None
    assert window.push(*steps[2])[2][0] == pytest.approx(3.0)


def test_n_step_window_keeps_members_apart():
    window = NStepWindow(2, 0.9)
    obs = np.zeros((2, OBS), np.float32)
    actions = np.array([0, 1])
    assert window.push(obs, actions, np.array([1.0, 10.0]), obs) is None
    _, _, ret, _ = window.push(obs, actions, np.array([2.0, 20.0]), obs)
    assert ret == pytest.approx([1 + 0.9 * 2, 10 + 0.9 * 20])


def test_one_step_window_passes_the_step_through():
    window = NStepWindow(1, 0.5)
    step = _step(3.0)
    assert all(a is b for a, b in zip(window.push(*step), step, strict=True))


def test_n_step_run_stores_discounted_sums_and_the_state_n_steps_later():
    n, gamma, steps = 3, 0.5, 10
    run = StackRun([Member(scenario(agent={"n_step": n, "gamma": gamma, "batch_size": 64},
                                    train={"steps": steps}), 4)])
    first = run.run_episode()[0]
    memory = run.algorithm.memory.arrays(0)
    assert len(memory["rewards"]) == steps - (n - 1) == 8
    r = first.trajectory["reward"]
    expected = [r[t] + gamma * r[t + 1] + gamma**2 * r[t + 2] for t in range(8)]
    assert np.allclose(memory["rewards"], np.float32(expected), rtol=1e-6, atol=0)
    assert np.array_equal(memory["actions"], first.trajectory["action"][:8])
    # row t holds s_t and s_{t+3}; row t + 3 starts from s_{t+3}
    assert np.array_equal(memory["next_observations"][:5], memory["observations"][3:8])
    assert not memory["terminated"].any()
    second = run.run_episode()[0]
    memory = run.algorithm.memory.arrays(0)
    assert len(memory["rewards"]) == 16                 # the window restarted: no row spans two
    r2 = second.trajectory["reward"]
    assert memory["rewards"][8] == pytest.approx(r2[0] + gamma * r2[1] + gamma**2 * r2[2],
                                                 rel=1e-6)


def test_replay_rows_of_an_n_step_run():
    n_step = scenario(agent={"n_step": 4, "memory_size": 50}, train={"steps": 20})
    assert replay_rows(n_step, 1, 4) == (17, 17)
    assert replay_rows(n_step, 2, 4) == (34, 34)
    assert replay_rows(n_step, 3, 4) == (50, 51 % 50)


def _dqn(**agent) -> StackedDqn:
    config = scenario(agent={"hidden_sizes": [8], "batch_size": 4, **agent}).agent
    return StackedDqn(config, OBS, 32, [0])


def _batch(seed: int = 0):
    rng = np.random.default_rng(seed)
    obs = torch.from_numpy(rng.normal(size=(1, 4, OBS)).astype(np.float32))
    nxt = torch.from_numpy(rng.normal(size=(1, 4, OBS)).astype(np.float32))
    actions = torch.from_numpy(rng.integers(32, size=(1, 4)))
    rewards = torch.tensor([[1.0, -2.0, 0.5, 3.0]])
    return obs, actions, rewards, nxt, torch.ones(1, 4)


@pytest.mark.parametrize(("n_step", "gamma"), [(1, 0.5), (3, 0.5), (2, 0.9)])
def test_td_target_bootstraps_with_gamma_to_the_n(n_step, gamma):
    dqn = _dqn(n_step=n_step, gamma=gamma, loss="mse")
    obs, actions, rewards, nxt, not_terminal = _batch()
    q = dqn.q_values(obs)[0].double().numpy()
    next_q = dqn.q_values(nxt)[0].double().numpy()          # target == policy at the start
    target = rewards[0].double().numpy() + gamma**n_step * next_q.max(axis=1)
    chosen = q[np.arange(4), actions[0].numpy()]
    dqn.update(obs, actions, rewards, nxt, not_terminal)
    assert dqn.loss_sum[0].item() == pytest.approx(np.mean((chosen - target) ** 2), rel=1e-5)


def test_soft_target_update_after_every_update():
    dqn = _dqn(target_tau=0.25)
    target = dqn.target.clone()
    dqn.update(*_batch())
    params = dqn.params.clone()
    assert not torch.equal(params, target)
    assert torch.allclose(dqn.target, target + 0.25 * (params - target), rtol=0, atol=1e-7)
    hard = _dqn()
    before = hard.target.clone()
    hard.update(*_batch())
    assert torch.equal(hard.target, before)          # tau = 0: only the hard copies


def test_a_soft_target_is_never_copied_hard():
    soft = StackRun([Member(scenario(agent={"target_tau": 0.1, "target_update_episodes": 1}),
                            2)])
    hard = StackRun([Member(scenario(agent={"target_update_episodes": 1}), 2)])
    for run in (soft, hard):
        run.run_episode()
        # the episode's losses taken, after updates
        assert run.algorithm.losses.counts["loss"] == 0 and run.algorithm.agent.step.item() > 0
    assert torch.equal(hard.algorithm.agent.target, hard.algorithm.agent.params)  # hard copy
    assert not torch.equal(soft.algorithm.agent.target, soft.algorithm.agent.params)


@pytest.mark.parametrize(("global_step", "lr"), [(0, 1e-3), (50, 5.5e-4), (100, 1e-4),
                                                 (400, 1e-4)])
def test_learning_rate_falls_linearly(global_step, lr):
    """Adam's first step moves every weight with a gradient by lr (m / sqrt(v) = +-1)."""
    dqn = _dqn(lr=1e-3, lr_end=1e-4, lr_decay_steps=100.0)
    dqn.set_learning_rate(global_step)
    before = dqn.params.clone()
    dqn.update(*_batch())
    moved = (dqn.params - before).abs()
    moved = moved[dqn.grads.abs() > 1e-4]
    assert len(moved) > 50
    assert moved.double().numpy() == pytest.approx(lr, rel=2e-3)


def test_learning_rate_is_set_at_every_episode_start():
    steps, episodes = 20, 3
    run = StackRun([Member(scenario(agent={"lr": 1e-3, "lr_end": 1e-4,
                                           "lr_decay_steps": 100.0}), 1)])
    seen = []
    original = run.algorithm.agent.set_learning_rate
    run.algorithm.agent.set_learning_rate = lambda step: (seen.append(step), original(step))[1]
    for _ in range(episodes):
        run.run_episode()
    assert seen == [0, 20, 40]
    assert seen == [steps * episode for episode in range(episodes)]
    assert float(run.algorithm.agent._lr) == pytest.approx(1e-3 + (1e-4 - 1e-3) * 40 / 100)


# ---- resume bit for bit --------------------------------------------------------------------

def _train_then_resume(tmp_path: Path, name: str, **kwargs) -> dict:
    path = write(tmp_path, name, **kwargs)
    straight, _ = api.train(scenario_path=path, out=tmp_path / f"{name}-4.h5", episodes=4,
                            workers=1, quiet=True)
    halves, _ = api.train(scenario_path=path, out=tmp_path / f"{name}-2.h5", episodes=2,
                          workers=1, quiet=True)
    assert main(["train", "--resume", str(halves), "--episodes", "4", "--workers", "1",
                 "--quiet"]) == 0
    (curves_a, state_a), (curves_b, state_b) = stored(straight), stored(halves)
    assert len(curves_a["sum_rate_bps"]) == 4
    assert_same_tree(curves_a, curves_b)
    assert_same_tree(state_a, state_b)
    return state_a


def test_n_step_tuned_run_resumes_bit_for_bit(tmp_path):
    n, steps = 3, 20
    state = _train_then_resume(tmp_path, "nstep", agent={"preset": "tuned", "n_step": n,
                                                          "hidden_sizes": [16, 16]})
    assert len(state["replay"]["actions"]) == min(200, 4 * (steps - (n - 1))) == 72
    # the soft target follows the weights but is not a copy of them
    policy, target = state["agent"]["policy"], state["agent"]["target"]
    assert not np.array_equal(policy["torso.0.weight"], target["torso.0.weight"])


# ---- fresh placement -----------------------------------------------------------------------

FRESH = {"count": 4, "placement": "fresh"}


def _by_hand(seed: int, episode: int, side_m: float = 100.0) -> np.ndarray:
    return np.random.default_rng([seed, 2, episode]).uniform(-side_m / 2, side_m / 2, (4, 2))


def test_fresh_layouts_are_drawn_per_seed_and_episode():
    fresh = scenario(users=FRESH, area={"side_m": 80.0})
    layouts = episode_layouts(fresh, [7, 8], 3)
    assert layouts.shape == (2, 4, 2)
    assert np.array_equal(layouts[0], _by_hand(7, 3, 80.0))
    assert np.array_equal(layouts[1], _by_hand(8, 3, 80.0))
    assert np.abs(layouts).max() <= 40.0
    assert not np.array_equal(episode_layouts(fresh, [7], 4)[0], layouts[0])


def test_fresh_training_takes_a_new_layout_every_episode_paired_near_far():
    run = StackRun([Member(scenario(users=FRESH), 5)])
    start = np.array(run.scenario.uav.start_m)
    for episode in range(3):
        run.run_episode()
        layout = _by_hand(5, episode)
        assert np.array_equal(run.env.layouts_m[0], layout)
        # mmWave, LoS always: the gain falls with distance, so nearest is strongest
        distance = np.hypot(np.hypot(*(layout - start[:2]).T), start[2])
        order = np.argsort(distance)
        assert list(run.env.first_user[0]) == [order[0], order[1]]
        assert list(run.env.second_user[0]) == [order[3], order[2]]


def test_fresh_placement_defaults_to_16_held_out_layouts():
    assert scenario(users=FRESH).train.eval_layouts == 16
    assert scenario(users={"count": 4, "placement": "uniform"}).train.eval_layouts == 0
    assert scenario().train.eval_layouts == 0
    assert scenario(users=FRESH, train={"eval_layouts": 2}).train.eval_layouts == 2
    defaults = make_scenario().train
    assert (defaults.eval_every, defaults.eval_steps, defaults.eval_layout_seed) == (10, 1000, 1)


def test_fresh_run_resumes_bit_for_bit_and_evaluates_on_layout_seed(tmp_path, capsys):
    users = {**FRESH, "layout_seed": 9}
    _train_then_resume(tmp_path, "fresh", users=users)
    run = tmp_path / "fresh-4.h5"
    with RunReader(run) as reader:
        assert reader.scenario.users.placement == "fresh"
    capsys.readouterr()
    assert main(["eval", "--checkpoint", str(run), "--steps", "5", "--compare", "",
                 "--json", "--out", str(tmp_path / "e.h5")]) == 0
    results = json.loads(capsys.readouterr().out)
    expected = np.random.default_rng(9).uniform(-50.0, 50.0, (1, 4, 2))
    assert np.array_equal(np.array(results["layouts_m"]), expected)


# ---- users in the observation cluster by cluster ----------------------------------------------

# four users at known distances from the start (0, 0): by gain (nearest first) 2, 0, 3, 1, so
# near-far pairs (2, 1) and (0, 3): cluster 1 is the strongest with the weakest
ORDER_LAYOUT_M = [[20.0, 0.0], [-45.0, 40.0], [0.0, 5.0], [30.0, -30.0]]


def test_clusters_order_lists_each_clusters_first_then_second_user():
    from adaptsky.envs.observations import AgentView
    from adaptsky.sim.network import NetworkBatch

    def batch(scenario):    # what the agent observes: the view its settings pick
        return NetworkBatch(scenario, view=AgentView.of(scenario))

    users = {"positions_m": ORDER_LAYOUT_M, "pairing": "near-far"}
    listed = batch(scenario(users=users))
    clustered = batch(scenario(users=users, agent={"user_order": "clusters"}))
    by_user, _ = listed.reset()
    by_cluster, _ = clustered.reset()
    blocks = by_user[0, :-1].reshape(4, 4)  # [dx, dy, alpha, g] per user, as listed
    assert np.array_equal(by_cluster[0, :-1].reshape(4, 4), blocks[[2, 1, 0, 3]])
    assert by_cluster[0, -1] == by_user[0, -1]  # the height stays last
    # dx of the first block is x_UAV - x_user2 = 0 - 0, of the second 0 - (-45) scaled by L/2
    assert by_cluster[0, 0] == 0.0 and by_cluster[0, 4] == np.float32(45.0 / 50.0)
    assert np.array_equal(clustered.observation(), by_cluster)
    # with the paper's listed pairing, clusters are (1, 2), (3, 4): the same order as listed
    paper = batch(scenario(agent={"user_order": "clusters"}))
    plain = batch(scenario())
    assert np.array_equal(paper.reset()[0], plain.reset()[0])


def test_eval_refuses_a_scenario_that_orders_users_otherwise(tmp_path, capsys):
    path = write(tmp_path, "run", train={"episodes": 2})
    run = tmp_path / "run.h5"
    assert main(["train", str(path), "--out", str(run), "--quiet"]) == 0
    other = write(tmp_path, "other", agent={"user_order": "clusters"})
    capsys.readouterr()
    assert main(["eval", "--checkpoint", str(run), "--scenario", str(other), "--steps", "5",
                 "--out", str(tmp_path / "e.h5")]) == 1
    err = capsys.readouterr().err.strip()
    assert "agent.user_order is 'clusters', the policy was trained with 'listed'" in err
    assert len(err.splitlines()) == 1 and not (tmp_path / "e.h5").exists()


def test_gym_env_draws_a_fresh_layout_at_every_reset(tmp_path):
    import gymnasium

    import adaptsky  # noqa: F401  (registers the environment)

    path = write(tmp_path, "fresh", users={"count": 4, "placement": "fresh"})
    env = gymnasium.make("adaptsky/NomaUav-v0", scenario=str(path)).unwrapped
    env.reset(seed=7)
    first = env.batch.users_m.copy()
    env.reset()
    second = env.batch.users_m.copy()
    assert not np.array_equal(first, second)
    expected = np.random.default_rng(7).uniform(-50.0, 50.0, size=(1, 4, 2))
    assert np.array_equal(first, expected)  # gymnasium seeds np_random as default_rng(seed)
    fixed = gymnasium.make("adaptsky/NomaUav-v0", scenario=str(path),
                           users_m=np.array(ORDER_LAYOUT_M)).unwrapped
    fixed.reset(seed=1)
    fixed.reset()
    assert np.array_equal(fixed.batch.users_m[0], ORDER_LAYOUT_M)
