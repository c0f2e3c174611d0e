"""The batched environment: start state, clipping at every bound, pairing, layouts, LoS modes,
observation scaling, seeding."""

import numpy as np
import pytest

from adaptsky.envs.observations import AgentView
from adaptsky.sim.layout import pair_users, user_layouts
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SUB6_RADIO, TRAINING_LAYOUT_M, make_scenario

LAYOUT = [list(p) for p in TRAINING_LAYOUT_M]


def _direction_action(env, directions):
    return env.actions.encode(np.array(directions))


def test_episode_starts_at_the_start_position_with_even_split(mmwave):
    env = NetworkBatch(mmwave, num_envs=2, seed=0)
    env.reset()
    env.step(np.array([31, 0]))
    _, state = env.reset()
    assert np.array_equal(state.uav_m, [[0, 0, 50], [0, 0, 50]])
    assert np.array_equal(state.alpha, np.full((2, 4), 0.5))
    assert env.t == 0


def test_a_step_moves_one_step_on_every_axis(mmwave):
    env = NetworkBatch(mmwave, seed=0)
    env.reset()
    _, _, _, state = env.step(np.array([_direction_action(env, [1, -1, 1, -1, 1])]))
    assert state.uav_m[0].tolist() == [1.0, -1.0, 51.0]
    assert state.alpha[0] == pytest.approx([0.49, 0.51, 0.51, 0.49])


@pytest.mark.parametrize(("axis", "direction", "bound"), [
    (0, 1, 50.0), (0, -1, -50.0), (1, 1, 50.0), (1, -1, -50.0), (2, 1, 60.0), (2, -1, 10.0)])
def test_moves_are_clipped_at_every_position_bound(axis, direction, bound):
    # start 3 m from the bound under test (h_max lowered to 60 m to keep the test short)
    start = [0.0, 0.0, 30.0]
    start[axis] = bound - 3.0 * direction
    scenario = make_scenario(uav={"start_m": start, "max_height_m": 60.0})
    env = NetworkBatch(scenario, seed=0)
    env.reset()
    directions = [1, 1, 1, 1, 1]
    directions[axis] = direction
    action = np.array([_direction_action(env, directions)])
    positions = [env.step(action)[3].uav_m[0, axis] for _ in range(6)]
    assert positions == pytest.approx([bound - 2 * direction, bound - direction] + [bound] * 4)


@pytest.mark.parametrize(("direction", "bound"), [(1, 0.99), (-1, 0.01)])
def test_alpha_is_clipped_to_power_step_bounds(mmwave, direction, bound):
    env = NetworkBatch(mmwave, seed=0)
    env.reset()
    action = np.array([_direction_action(env, [1, 1, 1, direction, -direction])])
    for _ in range(60):
        state = env.step(action)[3]
    assert state.alpha[0] == pytest.approx([bound, 1 - bound, 1 - bound, bound])


def test_episode_is_truncated_after_train_steps():
    env = NetworkBatch(make_scenario(train={"steps": 3}), seed=0)
    env.reset()
    flags = [env.step(np.array([0]))[2] for _ in range(3)]
    assert flags == [False, False, True]


def test_uniform_layouts_are_seeded_and_prefix_stable():
    scenario = make_scenario(users={"positions_m": None, "count": 6, "layout_seed": 3})
    five = user_layouts(scenario, 5)
    assert five.shape == (5, 6, 2)
    assert np.all(np.abs(five) <= 50)
    assert np.array_equal(user_layouts(scenario, 2), five[:2])
    assert not np.array_equal(user_layouts(scenario, 2, layout_seed=4), five[:2])
    assert scenario.users.pairing == "near-far"


def test_near_far_pairs_kth_strongest_with_kth_weakest():
    gains = np.array([[3.0, 1.0, 4.0, 2.0, 6.0, 5.0]])
    first, second = pair_users(gains, "near-far")
    # strongest 6 (index 4) with weakest 1 (index 1); 5 (5) with 2 (3); 4 (2) with 3 (0)
    assert first.tolist() == [[4, 5, 2]]
    assert second.tolist() == [[1, 3, 0]]


def test_listed_pairing_is_in_file_order():
    first, second = pair_users(np.zeros((2, 4)), "listed")
    assert first.tolist() == [[0, 2], [0, 2]] and second.tolist() == [[1, 3], [1, 3]]


def test_sampled_los_draws_nlos_at_low_elevation_and_expected_lies_between():
    # sub-6 at h = 10 m: users 2 and 4 are ~70 m away, theta ~ 8 deg < theta_0, never LoS
    base = {"radio": SUB6_RADIO, "uav": {"start_m": [0.0, 0.0, 10.0]}}
    gains = {}
    for mode in ("always", "sampled", "expected"):
        scenario = make_scenario(channel={"model": "sub6-al-hourani", "los": mode}, **base)
        state = NetworkBatch(scenario, num_envs=50, seed=1).reset()[1]
        gains[mode] = state.gain
        if mode == "sampled":
            assert not state.los[:, 1].any() and not state.los[:, 3].any()
    assert np.all(gains["expected"] <= gains["always"])
    assert np.all(gains["sampled"] <= gains["always"])
    nlos_only = gains["always"][:, 1] * 10**-1.9          # eta 20 dB instead of 1 dB
    assert gains["expected"][:, 1] == pytest.approx(nlos_only, rel=1e-12, abs=0.0)


def test_scaled_observation_by_hand(mmwave):
    env = NetworkBatch(mmwave, seed=0)
    obs, state = env.reset()
    # user 1 at (4, 15), UAV at (0, 0, 50): dx = -4 / 50, dy = -15 / 50
    gain_db = 10 * np.log10(state.gain[0, 0])
    assert obs[0, :4] == pytest.approx([-0.08, -0.3, 0.5, (gain_db + 100) / 20], rel=1e-6)
    assert obs[0, -1] == pytest.approx(50 / 200)
    assert obs.shape == (1, 17) and obs.dtype == np.float32


def test_raw_observation_is_the_papers_state():
    """The raw values, where the agent's view asks for them (the simulator's own are
    scaled: it reads no agent setting)."""
    raw = make_scenario(agent={"observation": "raw"})
    assert NetworkBatch(raw, seed=0).reset()[0][0, -1] == pytest.approx(
        50.0 / raw.uav.max_height_m, rel=1e-6)
    env = NetworkBatch(raw, seed=0, view=AgentView.of(raw))
    obs, state = env.reset()
    assert obs[0, 4:8] == pytest.approx([44.0, 49.0, 0.5, state.gain[0, 1]], rel=1e-6)
    assert obs[0, -1] == 50.0


def test_users_random_walk_at_their_speed(mmwave):
    scenario = make_scenario(users={"positions_m": LAYOUT, "speed_m_per_step": 2.0})
    env = NetworkBatch(scenario, num_envs=4, seed=0)
    env.reset()
    before = env.users_m.copy()
    env.step(np.zeros(4, dtype=int))
    moved = np.linalg.norm(env.users_m - before, axis=-1)
    inside = np.all(np.abs(before) < 48, axis=-1)       # not clipped by the area edge
    assert moved[inside] == pytest.approx(2.0)


def test_same_seed_same_rollout_bit_for_bit():
    scenario = make_scenario(radio=SUB6_RADIO,
                             users={"positions_m": LAYOUT, "speed_m_per_step": 1.0},
                             channel={"model": "sub6-al-hourani", "los": "sampled"})
    runs = []
    for _ in range(2):
        env = NetworkBatch(scenario, num_envs=8, seed=42)
        env.reset()
        actions = np.random.default_rng(5).integers(0, 32, size=(40, 8))
        runs.append(np.stack([env.step(a)[1] for a in actions]))
    assert np.array_equal(runs[0], runs[1])
    other = NetworkBatch(scenario, num_envs=8, seed=43)
    other.reset()
    assert not np.array_equal(runs[0][0], other.step(actions[0])[1])


def test_invalid_actions_are_rejected(mmwave):
    env = NetworkBatch(mmwave, num_envs=2, seed=0)
    env.reset()
    with pytest.raises(ValueError, match="actions must lie"):
        env.step(np.array([0, 32]))
    with pytest.raises(ValueError, match="expected 2 actions"):
        env.step(np.array([0]))
