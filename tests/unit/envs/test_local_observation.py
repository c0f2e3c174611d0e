"""Every UAV's local observation (docs/environment.md, "Local observations"): its values
against plain formulas from the positions, shares, gains and interference; its slots and UAV
rows against the global observation's; padding and the bounds of groups of different sizes."""

import math

import numpy as np
import pytest

from adaptsky.envs.observations import users_in_order
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.sim.observation import local_observation_bounds, multi_observation_bounds
from tests.conftest import SCENARIOS
from tests.helpers.scalar_models import ANTENNA_GAIN, TX_POWER_W, scalar_gain
from tests.unit.envs.several_uavs import STARTS_M, USERS_M, two_uavs, uneven

NOISE_W = 10 ** ((-84.0 - 30) / 10)       # the paper's mmWave noise: -84 dBm, 0 dB figure


def expected_local(uavs, alpha, scaled, side_m=100.0, max_height_m=200.0):
    """The local observation of each UAV of ``uneven()`` written out: per own user [dx, dy,
    alpha, g, I] (zeros past UAV 1's two users), then its own [x, y, h] and the other's."""
    groups = [[0, 1, 2, 3], [4, 5]]
    cluster = {0: 0, 1: 0, 2: 1, 3: 1, 4: 0, 5: 0}
    clusters = [2, 1]
    half = side_m / 2
    observations = []
    for u, group in enumerate(groups):
        values = []
        for i in group:
            x_i, y_i = USERS_M[i]
            g = scalar_gain(uavs[u], (x_i, y_i), "always")
            # full reuse: the other UAV's cluster on the same subchannel, if it has one
            other = 1 - u
            interference_w = (TX_POWER_W * ANTENNA_GAIN * scalar_gain(uavs[other], (x_i, y_i),
                                                                     "always")
                              if cluster[i] < clusters[other] else 0.0)
            dx, dy = uavs[u][0] - x_i, uavs[u][1] - y_i
            if scaled:
                values += [dx / half, dy / half, alpha[i], (10 * math.log10(g) + 100) / 20,
                           10 * math.log10(1 + interference_w / NOISE_W) / 20]
            else:
                values += [dx, dy, alpha[i], g, interference_w / NOISE_W]
        values += [0.0] * 5 * (4 - len(group))
        for v in (u, 1 - u):
            x, y, h = uavs[v]
            values += [x / half, y / half, h / max_height_m] if scaled else [x, y, h]
        observations.append(np.array(values))
    return observations


@pytest.mark.parametrize("observation", ["scaled", "raw"])
def test_local_observation_equals_the_plain_formulas(observation):
    env = NomaUavParallelEnv(uneven(observation), observation="local")
    association = env.env.batch.association
    assert association.first_user.tolist() == [[[0, 2], [4, -1]]]   # the clusters assumed
    observations, _ = env.reset(seed=0)
    scaled = observation == "scaled"
    for agent, values in zip(env.possible_agents,
                             expected_local(STARTS_M, [0.5] * 6, scaled), strict=True):
        assert observations[agent].dtype == np.float32 and observations[agent].shape == (26,)
        assert observations[agent] == pytest.approx(values, rel=1e-6, abs=1e-7)
    # UAV 0: x + 1 m, h - 1 m, alpha_1 + 0.01, alpha_2 - 0.01; UAV 1: y - 1 m, alpha_1 - 0.01
    observations, *_ = env.step({"uav_0": np.array([2, 1, 0, 2, 0]),
                                 "uav_1": np.array([1, 0, 1, 0])})
    uavs = [[-19.0, 0.0, 49.0], [25.0, -1.0, 50.0]]
    alpha = [0.51, 0.49, 0.49, 0.51, 0.49, 0.51]
    for agent, values in zip(env.possible_agents, expected_local(uavs, alpha, scaled),
                             strict=True):
        assert observations[agent] == pytest.approx(values, rel=1e-6, abs=1e-7)
    assert not observations["uav_1"][10:20].any()                  # UAV 1's padded slots
    assert all(env.observation_space(agent).contains(observations[agent])
               for agent in env.agents)


THREE_UAVS = load_scenario(SCENARIOS / "three_uavs_mmwave.toml")


@pytest.mark.parametrize("user_order", ["listed", "clusters"])
@pytest.mark.parametrize("scenario", [two_uavs(moving=True), uneven(), THREE_UAVS],
                         ids=["two-uavs", "uneven-groups", "three-uavs"])
def test_local_slots_are_the_global_observations_rows(scenario, user_order):
    """Agent u's user slots are the rows of the global observation (5 N + 3 U) of the users
    UAV u serves, in the global order, then zeros; its UAV rows are UAV u's, then the
    others' in UAV order."""
    data = scenario.model_dump(mode="json")
    data["agent"]["user_order"] = user_order
    scenario = parse_scenario(data, "local")
    env = NomaUavParallelEnv(scenario, observation="local")
    observations, _ = env.reset(seed=1)
    for _ in range(3):
        observations, *_ = env.step({agent: env.action_space(agent).sample()
                                     for agent in env.agents})
    batch = env.env.batch
    n, num_uavs = scenario.num_users, scenario.uav.count
    state = env.state()
    users, uav_rows = state[:5 * n].reshape(n, 5), state[5 * n:].reshape(num_uavs, 3)
    order = users_in_order(batch.association, user_order)
    order = np.arange(n) if order is None else order[0]
    serving = batch.association.serving_uav[0][order]      # in observation order
    slots = 2 * scenario.clusters_per_uav
    for u, agent in enumerate(env.possible_agents):
        own = users[serving == u]
        padded = np.zeros((slots - len(own), 5), dtype=np.float32)
        others = [v for v in range(num_uavs) if v != u]
        expected = np.concatenate([own.ravel(), padded.ravel(), uav_rows[[u, *others]].ravel()])
        assert np.array_equal(observations[agent], expected)


def test_padded_slots_widen_the_bounds_to_zero():
    """UAV 1 of ``uneven()`` pads slots 2-3: a gain range of -90 to -80 dB scales to
    [0.5, 1], which these slots widen to [0, 1]; UAV 0's own slots 0-1 keep it."""
    scenario = uneven()
    low, high = local_observation_bounds(scenario, (1e-9, 1e-8), scaled=True)
    global_low, global_high = multi_observation_bounds(scenario, (1e-9, 1e-8), scaled=True)
    assert low.dtype == np.float32 and low.shape == (26,)
    gain_low = low[3:20:5]
    assert gain_low[:2] == pytest.approx([0.5, 0.5]) and gain_low[2:].tolist() == [0.0, 0.0]
    assert np.array_equal(high[3:20:5], global_high[3:20:5])
    assert np.array_equal(low[:10], global_low[:10]) and np.array_equal(high[20:],
                                                                        global_high[30:])


def test_every_agent_has_one_space_and_state_stays_global():
    scenario = uneven(steps=2)
    local, whole = (NomaUavParallelEnv(scenario, observation=kind)
                    for kind in ("local", "global"))
    spaces = [local.observation_space(agent) for agent in local.possible_agents]
    assert spaces[0] == spaces[1] and spaces[0].shape == (5 * 4 + 3 * 2,)
    assert local.state_space == whole.state_space == whole.observation_space("uav_1")
    local.reset(seed=0)
    observations, _ = whole.reset(seed=0)
    assert np.array_equal(local.state(), observations["uav_0"])


def test_an_unknown_observation_kind_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"^observation must be 'global' or 'local', got "
                                         r"'partial'$"):
        NomaUavParallelEnv(uneven(), observation="partial")
