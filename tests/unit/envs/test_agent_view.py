"""The observation adapter the agent picks (adaptsky.envs.observations.AgentView): the users'
order and every UAV's local part, gathered from the network's observation (users as listed),
bit for bit the values of observing in that order."""

from __future__ import annotations

import numpy as np

from adaptsky.envs.observations import AgentView, LocalObserver, users_in_order
from adaptsky.scenario import parse_scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.observation import FEATURES_PER_USER
from tests.conftest import make_scenario
from tests.unit.envs.several_uavs import two_uavs, uneven


def stepped(scenario, view: AgentView | None, steps: int = 3) -> tuple[np.ndarray, NetworkBatch]:
    env = NetworkBatch(scenario, 3, seed=4, view=view)
    env.reset()
    actions = np.random.default_rng(2).integers(0, env.actions.count, size=(steps, 3))
    for action in actions:
        obs, *_ = env.step(action)
    return obs, env


def test_the_agent_picks_its_view() -> None:
    assert AgentView.of(make_scenario()) is None                    # the paper's: as listed
    clusters = AgentView.of(make_scenario(agent={"user_order": "clusters"}))
    assert clusters == AgentView("clusters", local=False, num_slots=4)
    data = two_uavs().model_dump(mode="json")
    data["agent"] = {"algorithm": "mappo"}
    assert AgentView.of(parse_scenario(data, "mappo")) == AgentView("listed", local=True,
                                                                    num_slots=4)


def test_clusters_order_permutes_the_users_of_the_papers_observation() -> None:
    """One UAV: the agent's observation is the network's with every user's four features
    moved to its place cluster by cluster (first, then second user), h last."""
    scenario = make_scenario(agent={"user_order": "clusters"},
                             users={"positions_m": [[-5.0, 3.0], [8.0, -4.0], [40.0, -30.0],
                                                    [-45.0, -8.0]], "pairing": "near-far"})
    view = AgentView.of(scenario)
    listed, env = stepped(scenario, None)
    ordered, other = stepped(scenario, view)
    order = users_in_order(env.association, "clusters")
    assert order is not None and not (order == np.arange(4)).all()   # a real permutation
    users = listed[:, :-1].reshape(3, 4, FEATURES_PER_USER)
    expected = np.concatenate([np.take_along_axis(users, order[..., None], axis=1).reshape(3, -1),
                               listed[:, -1:]], axis=1)
    assert ordered.dtype == np.float32
    np.testing.assert_array_equal(ordered, expected)
    np.testing.assert_array_equal(other.state.rate_bps, env.state.rate_bps)   # only the view


def test_local_view_equals_every_uavs_local_observation() -> None:
    """MAPPO's view (U local observations one after the other) is LocalObserver's from the
    network's state, users in the agent's order."""
    data = two_uavs(moving=True).model_dump(mode="json")
    data["agent"] = {"algorithm": "mappo", "user_order": "clusters"}
    scenario = parse_scenario(data, "mappo")
    obs, env = stepped(scenario, AgentView.of(scenario), steps=4)
    state = env.state
    local = LocalObserver(scenario)(state.uav_m, env.users_m, env.association.serving_uav,
                                    state.alpha, state.gain, state.interference_w,
                                    users_in_order(env.association, "clusters"))
    assert obs.shape == (3, 52)
    np.testing.assert_array_equal(obs, local.reshape(3, -1))


def test_local_view_pads_the_slots_of_a_uav_with_fewer_users() -> None:
    """UAV 1 of ``uneven()`` serves two users of four slots: its last two slots are zeros
    in MAPPO's view, as in LocalObserver's, raw values and clusters order alike."""

    data = uneven(observation="raw", user_order="clusters").model_dump(mode="json")
    data["agent"] = {"algorithm": "mappo", "observation": "raw", "user_order": "clusters"}
    scenario = parse_scenario(data, "uneven-mappo")
    view = AgentView.of(scenario)
    assert view == AgentView("clusters", local=True, num_slots=4, scaled=False)
    obs, env = stepped(scenario, view)
    state = env.state
    local = LocalObserver(scenario)(state.uav_m, env.users_m, env.association.serving_uav,
                                    state.alpha, state.gain, state.interference_w,
                                    users_in_order(env.association, "clusters"))
    np.testing.assert_array_equal(obs, local.reshape(3, -1))
    second_uav = obs.reshape(3, 2, -1)[:, 1]
    assert (second_uav[:, 10:20] == 0).all() and (second_uav[:, :10] != 0).any()
