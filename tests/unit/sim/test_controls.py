"""Action kinds as adapters onto the controls of a step (docs/model.md §3): continuous moves
and share changes, absolute shares and the dense kinds against numbers written by hand from
the formulas, and the checks of continuous actions."""

from __future__ import annotations

from typing import get_args

import numpy as np
import pytest

from adaptsky.scenario import load_scenario
from adaptsky.scenario.models import Uav
from adaptsky.sim.actions import TABLE_MAX_ACTIONS
from adaptsky.sim.controls import CONTROLS, ContinuousControls, DenseControls
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.state import Dynamics, SimState, step
from tests.conftest import SCENARIOS, TRAINING_LAYOUT_M, make_scenario

USERS_M = [[list(p) for p in TRAINING_LAYOUT_M]]          # (B = 1, N = 4, 2)
# steps of 2, 3 and 4 m, share steps of 0.05: every axis has its own size
UAV = {"step_m": [2.0, 3.0, 4.0], "power_step": 0.05, "actions": "continuous"}


def _state(uav_m, alpha_first):
    return SimState.of([[uav_m]], [[alpha_first]], USERS_M)


def test_every_action_kind_has_an_adapter():
    kinds = get_args(Uav.model_fields["actions"].annotation)
    assert set(CONTROLS) == set(kinds) == {"paper", "with-hover", "continuous"}
    assert isinstance(Dynamics.of(make_scenario(), 1).controls, DenseControls)
    assert isinstance(Dynamics.of(make_scenario(uav=UAV), 1).controls, ContinuousControls)


def test_a_continuous_action_moves_by_a_times_the_step():
    dynamics = Dynamics.of(make_scenario(uav=UAV), num_envs=1)
    action = np.array([[0.5, -1.0, 0.25, 1.0, -0.4]])
    after = step(_state([10.0, -20.0, 30.0], [0.5, 0.3]), action, dynamics)
    # x + 0.5 * 2, y - 1 * 3, h + 0.25 * 4; alpha_1 + 1 * 0.05, alpha_2 - 0.4 * 0.05
    np.testing.assert_allclose(after.uav_m[0, 0], [11.0, -23.0, 31.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(after.alpha_first[0, 0], [0.55, 0.28], rtol=0, atol=1e-12)
    assert after.t == 1


def test_a_continuous_action_is_clipped_to_the_feasible_set():
    dynamics = Dynamics.of(make_scenario(uav=UAV), num_envs=1)
    # from x = L/2 - 1 = 49, y = -49.5, h = h_max - 1 = 199, alpha = (0.93, 0.07): every
    # component at full size leaves the set: x 51 -> 50, y -52.5 -> -50, h 203 -> 200,
    # alpha 0.98 -> 0.95 and 0.02 -> 0.05 (delta_alpha <= alpha <= 1 - delta_alpha)
    after = step(_state([49.0, -49.5, 199.0], [0.93, 0.07]),
                 np.array([[1.0, -1.0, 1.0, 1.0, -1.0]]), dynamics)
    assert after.uav_m[0, 0].tolist() == [50.0, -50.0, 200.0]
    assert after.alpha_first[0, 0].tolist() == [0.95, 0.05]
    # h_min = 10: from 11 m down by 4 m stops at 10
    after = step(_state([0.0, 0.0, 11.0], [0.5, 0.5]), np.array([[0, 0, -1.0, 0, 0]]),
                 dynamics)
    assert after.uav_m[0, 0].tolist() == [0.0, 0.0, 10.0]


@pytest.mark.parametrize(("a", "alpha"), [
    (-1.0, 0.05),                        # d
    (1.0, 0.95),                         # 1 - d
    (0.0, 0.5),                          # d + (1 - 2 d) / 2
    (0.5, 0.05 + 0.9 * 0.75),            # d + (1 - 2 d) (a + 1) / 2
    (-0.6, 0.05 + 0.9 * 0.2),
])
def test_absolute_power_sets_the_share(a, alpha):
    dynamics = Dynamics.of(make_scenario(uav=UAV | {"power": "absolute"}), num_envs=1)
    after = step(_state([10.0, -20.0, 30.0], [0.3, 0.8]),
                 np.array([[0.5, 0.0, -0.5, a, -a]]), dynamics)
    # the position still moves by a * step: x + 1, h - 2
    np.testing.assert_allclose(after.uav_m[0, 0], [11.0, -20.0, 28.0], rtol=0, atol=1e-12)
    # the shares do not depend on where they were; -a gives 1 - alpha (the formula is odd)
    np.testing.assert_allclose(after.alpha_first[0, 0], [alpha, 1.0 - alpha], rtol=0,
                               atol=1e-12)


def test_absolute_power_leaves_the_unused_share_slots_of_smaller_groups():
    # UAV 0 serves two clusters, UAV 1 one: UAV 1's second share slot is padding
    scenario = make_scenario(
        uav=UAV | {"power": "absolute", "count": 2,
                   "start_positions_m": [[-20.0, 0.0, 50.0], [20.0, 0.0, 50.0]]},
        users={"association": "listed", "uav": [0, 0, 0, 0, 1, 1],
               "positions_m": [[-30, 5], [-25, -5], [-20, 10], [-15, -10], [20, 5],
                               [25, -5]]})
    dynamics = Dynamics.of(scenario, num_envs=1)
    assert dynamics.controls.num_components == (3 + 2) + (3 + 1)
    before = SimState.of([[[-20.0, 0.0, 50.0], [20.0, 0.0, 50.0]]],
                         [[[0.5, 0.5], [0.5, 0.123]]], [scenario.users.positions_m])
    # UAV 0: x, y, h, cluster 1, cluster 2; UAV 1: x + 1 * 2 m, y, h, its cluster at a = 0
    action = np.array([[0.0, 0.0, 0.0, 1.0, -1.0, 1.0, 0.0, 0.0, 0.0]])
    after = step(before, action, dynamics)
    np.testing.assert_allclose(after.alpha_first[0], [[0.95, 0.05], [0.5, 0.123]], rtol=0,
                               atol=1e-12)
    assert after.uav_m[0].tolist() == [[-20.0, 0.0, 50.0], [22.0, 0.0, 50.0]]


def _decoded(action, base, components):
    """Directions of a dense index, digit j = (a // base^j) % base (docs/model.md §3)."""
    digits = [(action // base**j) % base for j in range(components)]
    return [2 * d - 1 if base == 2 else d - 1 for d in digits]


@pytest.mark.parametrize(("scenario_file", "mode", "step_m", "power_step"), [
    ("nyc_mmwave.toml", "paper", [1.0, 1.0, 1.0], 0.01),
    ("nyc_mmwave.toml", "with-hover", [1.5, 0.5, 2.0], 0.03),
    ("two_uavs_mmwave.toml", "paper", [1.0, 2.0, 3.0], 0.02),
    ("three_uavs_mmwave.toml", "paper", [1.0, 2.0, 3.0], 0.02),   # 2^15: decoded, no table
])
def test_the_dense_kinds_step_as_the_index_decoded_by_hand(scenario_file, mode, step_m,
                                                         power_step):
    base_scenario = load_scenario(SCENARIOS / scenario_file)
    data = base_scenario.model_dump()
    data["uav"] |= {"actions": mode, "step_m": step_m, "power_step": power_step}
    scenario = type(base_scenario).model_validate(data)
    num_uavs, k = scenario.uav.count, scenario.clusters_per_uav
    base, components = (2 if mode == "paper" else 3), num_uavs * (3 + k)
    count = base**components
    rng = np.random.default_rng(5)
    num_envs = 64
    half_m = scenario.area.side_m / 2
    config = np.concatenate([rng.uniform(-half_m, half_m, (num_envs, num_uavs, 2)),
                             rng.uniform(10.0, 200.0, (num_envs, num_uavs, 1)),
                             rng.uniform(0.0, 1.0, (num_envs, num_uavs, k))], axis=-1)
    state = SimState(config, np.zeros((num_envs, 4, 2)), 0)
    dynamics = Dynamics.of(scenario, num_envs)
    assert (dynamics.controls.moves is None) == (count > TABLE_MAX_ACTIONS)
    steps = [*step_m, *[power_step] * k] * num_uavs
    low = [-half_m, -half_m, 10.0, *[power_step] * k] * num_uavs
    high = [half_m, half_m, 200.0, *[1 - power_step] * k] * num_uavs
    for _ in range(4):
        actions = rng.integers(0, count, num_envs)
        after = step(state, actions, dynamics)
        expected = np.empty_like(config)
        for b, action in enumerate(actions.tolist()):
            flat = config[b].reshape(-1)
            moved = [min(max(flat[j] + d * steps[j], low[j]), high[j])
                     for j, d in enumerate(_decoded(action, base, components))]
            expected[b] = np.reshape(moved, (num_uavs, 3 + k))
        assert np.array_equal(after.config, expected)     # bit for bit
        config, state = after.config, after


def test_the_batch_steps_continuous_actions():
    env = NetworkBatch(make_scenario(uav=UAV), num_envs=2, seed=0)
    env.reset()
    obs, reward, _, state = env.step(np.array([[1, 0, 0, 0, 0], [0, -1, 0, 1, 0]],
                                              dtype=np.float32))
    assert state.uav_m.tolist() == [[2.0, 0.0, 50.0], [0.0, -3.0, 50.0]]
    assert np.isfinite(reward).all() and np.isfinite(obs).all()


def test_continuous_actions_are_checked_in_one_line():
    dynamics = Dynamics.of(make_scenario(uav=UAV), num_envs=2)
    good = np.zeros((2, 5))
    cases = [
        (np.zeros((2, 4)), r"^expected continuous actions of shape \(2, 5\) \(numbers in "
                           r"\[-1, 1\]\), got shape \(2, 4\) of float64$"),
        (np.zeros(2, dtype=np.int64), r"got shape \(2,\) of int64$"),
        (np.array([["a"] * 5] * 2), r"got shape \(2, 5\) of <U1$"),
        (np.where(np.eye(2, 5) > 0, np.nan, good), r"^continuous actions must be finite "
                                                    r"numbers in \[-1, 1\], got NaN or "
                                                    r"infinity$"),
        (np.full((2, 5), np.inf), r"got NaN or infinity$"),
        (np.full((2, 5), 1.5), r"^continuous actions must lie in \[-1, 1\], got values from "
                               r"1.5 to 1.5 \(clip them, e.g. gymnasium.wrappers.ClipAction\)$"),
        (np.array([[-1.0001, 0, 0, 0, 0], [0] * 5]), r"got values from -1.0001 to 0"),
    ]
    for actions, message in cases:
        with pytest.raises(ValueError, match=message):
            dynamics.checked(actions)
    assert dynamics.checked(np.array([[-1, 1, 0, 0, 0]] * 2, dtype=np.float32)).dtype \
        == np.float64
