"""The observation space's bounds are finite and hold every observation (issue 22, item 12):
gains between the weakest and strongest link the scenario's geometry allows
(adaptsky.sim.gain_bounds, docs/environment.md), raw and scaled."""

from __future__ import annotations

import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from adaptsky.envs.gym_env import NomaUavEnv, NomaUavVectorEnv
from adaptsky.scenario import load_scenario
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario

# a small world whose corners and height bounds random actions reach within an episode; steps
# that are not binary fractions, so the UAV's height carries rounding
SMALL = {"area": {"side_m": 12.0}, "users": {"positions_m": None, "count": 4,
                                             "speed_m_per_step": 0.7},
         "uav": {"start_m": [0.0, 0.0, 12.3], "min_height_m": 10.0, "max_height_m": 15.0,
                 "step_m": [0.9, 1.1, 0.3]}}
CASES = {
    "mmwave-always": {},
    "mmwave-sampled": {"channel": {"los": "sampled"}},
    "sub6-expected": {"radio": SUB6_RADIO, "channel": {"model": "sub6-al-hourani",
                                                        "los": "expected"}},
    "uma-sampled-1.5m": {"radio": SUB6_RADIO, "users": {"height_m": 1.5},
                         "channel": {"model": "uma-av", "los": "sampled"}},
    "uma-shadowing": {"radio": SUB6_RADIO, "channel": {
        "model": "uma-av", "los": "sampled", "params": {"shadowing": True}}},
}


def _scenario(case: str, observation: str, **extra):
    sections = {key: dict(value) for key, value in SMALL.items()}
    for key, value in {**CASES[case], **extra}.items():
        sections[key] = {**sections.get(key, {}), **value}
    sections["agent"] = {"observation": observation}
    return make_scenario(**sections, train={"steps": 400})


@pytest.mark.parametrize("observation", ["scaled", "raw"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_every_observation_lies_inside_the_finite_bounds(case, observation):
    env = NomaUavVectorEnv(_scenario(case, observation), num_envs=32)
    space = env.single_observation_space
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()
    obs, _ = env.reset(seed=1)
    rng = np.random.default_rng(2)
    gains = []
    for _ in range(400):
        assert all(space.contains(row) for row in obs), (case, observation)
        obs, _, _, _, info = env.step(rng.integers(env.single_action_space.n, size=32))
        gains.append(info["gain"])
    if case.endswith("always"):  # the bounds are the extremes of the geometry: nearly reached
        low, high = env.batch.gain_bounds()
        reached = np.array(gains)
        assert 10 * math.log10(reached.max() / high) > -0.5
        assert 10 * math.log10(reached.min() / low) < 3.0


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.toml")), ids=lambda p: p.name)
def test_shipped_scenarios_have_finite_bounds_and_check_env_is_quiet(path):
    scenario = load_scenario(path)
    env = gymnasium.make("adaptsky/NomaUav-v0", scenario=scenario.model_copy(
        update={"train": scenario.train.model_copy(update={"steps": 20})}))
    assert np.isfinite(env.observation_space.low).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # check_env warned: the bounds were infinite
        check_env(env.unwrapped)


def test_mmwave_gain_bounds_are_eq_5_at_the_shortest_and_longest_link():
    env = NomaUavEnv(SCENARIOS / "nyc_mmwave.toml")
    low, high = env.batch.gain_bounds()
    # LoS always: g = C_LoS d^-2, C_LoS = -64 dB; d from h_min = 10 m to sqrt(2 L^2 + h_max^2)
    longest_m = math.sqrt(2 * 100.0 ** 2 + 200.0 ** 2)
    assert 10 * math.log10(high) == pytest.approx(-64.0 - 20.0, abs=1e-6)
    assert 10 * math.log10(low) == pytest.approx(-64.0 - 20 * math.log10(longest_m), abs=1e-6)
    # scaled (g_dB + 100) / 20: about -0.589 to 0.8
    assert env.observation_space.low[3] == pytest.approx((10 * math.log10(low) + 100) / 20)
    assert env.observation_space.high[3] == pytest.approx(0.8)


def test_the_reachable_heights_are_the_three_lattices():
    from adaptsky.sim.gain_bounds import reachable_heights

    uav = make_scenario(uav={"start_m": [0.0, 0.0, 12.5], "min_height_m": 10.0,
                             "max_height_m": 14.0, "step_m": [1.0, 1.0, 1.5]}).uav
    assert reachable_heights(uav).tolist() == [10.0, 11.0, 11.5, 12.5, 13.0, 14.0]
