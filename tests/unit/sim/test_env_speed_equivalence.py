"""The fast step of NetworkBatch against a straightforward reference built from the pure
functions (noma.py, the channel plugins, pair_users), written the way the batch did before it
was tuned for small B: the same observations, rewards and states, environment by environment.
"""

from __future__ import annotations

import numpy as np
import pytest

from adaptsky.channels.contract import LinkGeometry
from adaptsky.envs.observations import AgentView
from adaptsky.sim import noma
from adaptsky.sim.layout import pair_users, user_layouts
from adaptsky.sim.links import build_channel, deterministic_gain
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.observation import GAIN_DB_CENTER, GAIN_DB_SCALE
from adaptsky.sim.reward import reward_weights
from tests.conftest import SCENARIOS, SUB6_RADIO, TRAINING_LAYOUT_M, make_scenario

FIELDS = ("uav_m", "alpha", "gain", "los", "p_los", "rate_bps", "sum_rate_bps", "fairness",
          "reward")
LAYOUT = [list(p) for p in TRAINING_LAYOUT_M]
UNIFORM = {"positions_m": None, "count": 6, "placement": "uniform", "layout_seed": 3,
           "pairing": "near-far"}


def _reward(rates, gains, fairness, bandwidth_hz, weights):
    """Eq. 13 written plainly, term after term (as noma.reward was before its terms)."""
    min_rate_bps = np.asarray(weights.min_rate_bps)
    satisfied = rates >= min_rate_bps[..., None]
    se = rates / bandwidth_hz
    value = weights.w_rate * se.sum(axis=-1) * satisfied.all(axis=-1)
    value = value + np.where(min_rate_bps == 0, weights.w_fairness * fairness, 0.0)
    value = value + weights.w_gain * gains.sum(axis=-1)
    value = value + weights.w_satisfied * satisfied.sum(axis=-1)
    return value + weights.w_unsatisfied * np.where(satisfied, 0.0, se).sum(axis=-1)


def _geometry(uav_m, users_m):
    """LinkGeometry.between as first written."""
    delta = users_m - uav_m[:, None, :2]
    horizontal_m = np.hypot(delta[..., 0], delta[..., 1])
    height_m = np.broadcast_to(uav_m[:, 2:3], horizontal_m.shape)
    distance_m = np.hypot(horizontal_m, height_m)
    elevation_deg = np.degrees(np.arcsin(height_m / distance_m))
    return LinkGeometry(horizontal_m, height_m, distance_m, elevation_deg)


class Reference:
    """The environment's step, written plainly: one pure function per equation."""

    def __init__(self, scenario, num_envs, seed, weights=None):
        self.scenario, self.num_envs = scenario, num_envs
        self.channel = build_channel(scenario)
        self.weights = reward_weights(scenario) if weights is None else noma.stack_weights(
            weights)
        radio = scenario.radio
        self.snr_scale = radio.tx_power_w * radio.antenna_gain / radio.noise_w
        self.layouts_m = user_layouts(scenario, num_envs)
        start = np.broadcast_to(np.array(scenario.uav.start_m), (num_envs, 3))
        gain = deterministic_gain(self.channel, scenario.channel.los,
                                  _geometry(start, self.layouts_m))
        self.first, self.second = pair_users(gain, scenario.users.pairing)
        self.rngs = ([np.random.default_rng(s) for s in seed] if isinstance(seed, list)
                     else None)
        self.rng = np.random.default_rng(None if isinstance(seed, list) else seed)
        uav = scenario.uav
        half_m = scenario.area.side_m / 2
        self.low = np.array([-half_m, -half_m, uav.min_height_m])
        self.high = np.array([half_m, half_m, uav.max_height_m])

    def reset(self):
        self.t = 0
        self.uav_m = np.broadcast_to(np.array(self.scenario.uav.start_m),
                                     (self.num_envs, 3)).copy()
        self.users_m = self.layouts_m.copy()
        self.alpha_first = np.full((self.num_envs, self.scenario.num_clusters),
                                   self.scenario.uav.start_alpha)
        return self.evaluate()

    def step(self, actions, action_set):
        directions = action_set.decode(actions)
        power_step = self.scenario.uav.power_step
        moved = self.uav_m + directions[:, :3] * np.array(self.scenario.uav.step_m)
        self.uav_m = np.minimum(np.maximum(moved, self.low), self.high)
        alpha = self.alpha_first + directions[:, 3:] * power_step
        self.alpha_first = np.minimum(np.maximum(alpha, power_step), 1.0 - power_step)
        speed = self.scenario.users.speed_m_per_step
        if speed:
            if self.rngs is None:
                heading = self.rng.uniform(0.0, 2 * np.pi, size=self.users_m.shape[:2])
            else:
                heading = np.stack([rng.uniform(0.0, 2 * np.pi, size=self.users_m.shape[1])
                                    for rng in self.rngs])
            step = speed * np.stack([np.cos(heading), np.sin(heading)], axis=-1)
            half_m = self.scenario.area.side_m / 2
            self.users_m = np.clip(self.users_m + step, -half_m, half_m)
        self.t += 1
        return self.evaluate()

    def _to_users(self, first, second):
        values = np.empty((self.num_envs, 2 * self.first.shape[1]))
        rows = np.arange(self.num_envs)[:, None]
        values[rows, self.first] = first
        values[rows, self.second] = second
        return values

    def evaluate(self):
        channel, mode = self.channel, self.scenario.channel.los
        geometry = _geometry(self.uav_m, self.users_m)
        p_los = channel.los_probability(geometry)
        if mode == "always":
            gain, los = channel.gain_los(geometry), np.ones(geometry.shape, dtype=bool)
        elif mode == "sampled":
            if self.rngs is None:
                los = channel.sample_los(geometry, self.rng)
            else:
                los = np.concatenate([channel.sample_los(geometry.rows(b, b + 1), rng)
                                      for b, rng in enumerate(self.rngs)])
            gain = np.where(los, channel.gain_los(geometry), channel.gain_nlos(geometry))
        else:
            gain, los = channel.expected_gain(geometry), p_los > 0.5
        rows = np.arange(self.num_envs)[:, None]
        sinr_first, sinr_second = noma.cluster_sinr(
            self.alpha_first, gain[rows, self.first], gain[rows, self.second], self.snr_scale)
        bandwidth_hz = self.scenario.radio.bandwidth_hz
        rates = self._to_users(noma.rate_bps(sinr_first, bandwidth_hz),
                               noma.rate_bps(sinr_second, bandwidth_hz))
        fairness = noma.jain_fairness(rates)
        state = {"uav_m": self.uav_m.copy(),
                 "alpha": self._to_users(self.alpha_first, 1.0 - self.alpha_first),
                 "gain": gain, "los": los, "p_los": p_los, "rate_bps": rates,
                 "sum_rate_bps": rates.sum(axis=1), "fairness": fairness,
                 "reward": _reward(rates, gain, fairness, bandwidth_hz, self.weights)}
        return self.observe(state), state

    def observe(self, state):
        delta = self.uav_m[:, None, :2] - self.users_m
        height, gain = self.uav_m[:, 2:3], state["gain"]
        if self.scenario.agent.observation == "scaled":
            delta = delta / (self.scenario.area.side_m / 2)
            gain = (10 * np.log10(gain) - GAIN_DB_CENTER) / GAIN_DB_SCALE
            height = height / self.scenario.uav.max_height_m
        per_user = np.stack([delta[..., 0], delta[..., 1], state["alpha"], gain], axis=-1)
        flat = per_user.reshape(per_user.shape[0], -1)
        return np.concatenate([flat, height], axis=1).astype(np.float32)


def _assert_same(obs, state, ref_obs, ref_state):
    # float64 to within its rounding (bit for bit on the machine this was tuned on), the
    # float32 observation to within one float32 rounding of that
    np.testing.assert_allclose(obs, ref_obs, rtol=2.0**-23, atol=0.0)
    for name in FIELDS:
        value, expected = getattr(state, name), ref_state[name]
        assert value.shape == expected.shape, name
        if value.dtype == bool:
            assert np.array_equal(value, expected), name
        else:
            np.testing.assert_allclose(value, expected, rtol=1e-12, atol=0.0, err_msg=name)


def _scenario(case):
    los_sampled_moving = {"users": {"positions_m": LAYOUT, "speed_m_per_step": 1.5},
                          "channel": {"los": "sampled"}}
    cases = {
        "nyc_file": lambda: _from_file("nyc_mmwave.toml"),
        "sub6_file": lambda: _from_file("sub6_al_hourani.toml"),
        "mmwave_sampled_moving": lambda: make_scenario(**los_sampled_moving),
        "sub6_sampled_moving": lambda: make_scenario(
            radio=SUB6_RADIO, users=los_sampled_moving["users"],
            channel={"model": "sub6-al-hourani", "los": "sampled"}),
        "sub6_expected_uniform_rewards": lambda: make_scenario(
            radio=SUB6_RADIO, users=UNIFORM, channel={"model": "sub6-al-hourani",
                                                      "los": "expected"},
            reward={"min_se": 2.0, "w_fairness": 0.5, "w_gain": 1e6, "w_satisfied": 0.3,
                    "w_unsatisfied": 2.0}),
        "mmwave_hover_raw_fairness": lambda: make_scenario(
            users=UNIFORM, uav={"actions": "with-hover"}, agent={"observation": "raw"},
            reward={"w_fairness": 2.0, "w_gain": 1e9, "w_satisfied": 0.1}),
        # 3^(3 + 5) actions: decoded, not looked up in a table
        "mmwave_hover_decoded": lambda: make_scenario(
            users={**UNIFORM, "count": 10}, uav={"actions": "with-hover"},
            channel={"los": "expected"}),
    }
    scenario = cases[case]()
    return scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"steps": 25})})


def _from_file(name):
    from adaptsky.scenario import load_scenario
    return load_scenario(SCENARIOS / name)


@pytest.mark.parametrize("case", ["nyc_file", "sub6_file", "mmwave_sampled_moving",
                                  "sub6_sampled_moving", "sub6_expected_uniform_rewards",
                                  "mmwave_hover_raw_fairness", "mmwave_hover_decoded"])
@pytest.mark.parametrize(("num_envs", "seeds"), [(1, "list"), (3, "list"), (3, "int")])
def test_step_equals_the_plain_reference(case, num_envs, seeds):
    scenario = _scenario(case)
    seed = [np.random.SeedSequence([b, 4]) for b in range(num_envs)] if seeds == "list" else 11
    env = NetworkBatch(scenario, num_envs, seed=seed, view=AgentView.of(scenario))
    ref = Reference(scenario, num_envs, seed)
    actions = np.random.default_rng(num_envs).integers(0, env.actions.count,
                                                       size=(60, num_envs))
    _assert_same(*env.reset(), *ref.reset())
    for a in actions:
        if env.t >= env.max_steps:
            _assert_same(*env.reset(), *ref.reset())
        obs, reward, _, state = env.step(a)
        ref_obs, ref_state = ref.step(a, env.actions)
        _assert_same(obs, state, ref_obs, ref_state)
        assert np.array_equal(reward, state.reward)
        assert np.array_equal(env.observation(), obs)
        np.testing.assert_allclose(env.users_m, ref.users_m, rtol=1e-12, atol=0.0)


def test_per_environment_weights_equal_the_plain_reference():
    scenario = _scenario("sub6_sampled_moving")
    weights = [noma.RewardWeights(w_rate=1.0 + b, w_fairness=0.2 * b, w_gain=1e6 * (b % 2),
                                  w_satisfied=0.1 * b, w_unsatisfied=0.5 * b,
                                  min_rate_bps=0.0 if b != 1 else 2.0 * 50e6)
               for b in range(3)]
    for chosen in (weights, [w for w in weights if w.min_rate_bps == 0]):
        seed = [np.random.SeedSequence([b, 4]) for b in range(len(chosen))]
        env = NetworkBatch(scenario, len(chosen), seed=seed, weights=chosen)
        ref = Reference(scenario, len(chosen), seed, weights=chosen)
        _assert_same(*env.reset(), *ref.reset())
        for a in np.random.default_rng(0).integers(0, 32, size=(20, len(chosen))):
            _assert_same(*env.step(a)[::3], *ref.step(a, env.actions))


def test_evaluate_at_equals_the_plain_reference():
    scenario = _scenario("sub6_expected_uniform_rewards")
    env, ref = NetworkBatch(scenario, 4, seed=0), Reference(scenario, 4, 0)
    env.reset(), ref.reset()
    rng = np.random.default_rng(2)
    for _ in range(5):
        uav_m = np.column_stack([rng.uniform(-50, 50, 4), rng.uniform(-50, 50, 4),
                                 rng.uniform(10, 200, 4)])
        alpha_first = rng.uniform(0.0, 1.0, (4, 3))
        alpha_first[0] = 1.0                  # a weak user with no power at all
        ref.uav_m, ref.alpha_first = uav_m, alpha_first
        state = env.evaluate_at(uav_m, alpha_first)
        _assert_same(env.observation(), state, *ref.evaluate())


@pytest.mark.parametrize("case", ["mmwave_sampled_moving", "sub6_expected_uniform_rewards"])
def test_an_environment_does_not_depend_on_its_neighbours(case):
    scenario = _scenario(case)
    seeds = [np.random.SeedSequence([b, 7]) for b in range(4)]
    actions = np.random.default_rng(3).integers(0, 32, size=(30, 4))
    stacked = NetworkBatch(scenario, 4, seed=seeds, users_m=user_layouts(scenario, 4))
    stacked.reset()
    alone = []
    for b in range(4):
        env = NetworkBatch(scenario, 1, seed=[seeds[b]],
                           users_m=user_layouts(scenario, 4)[b:b + 1])
        env.reset()
        alone.append(env)
    for a in actions:
        obs, _, _, state = stacked.step(a)
        for b, env in enumerate(alone):
            obs_b, _, _, state_b = env.step(a[b:b + 1])
            assert np.array_equal(obs[b:b + 1], obs_b)
            for name in FIELDS:
                assert np.array_equal(getattr(state, name)[b:b + 1],
                                      getattr(state_b, name)), name


def test_states_are_not_changed_by_later_steps():
    env = NetworkBatch(_scenario("mmwave_sampled_moving"), 2, seed=1)
    obs, state = env.reset()
    kept = {name: getattr(state, name).copy() for name in FIELDS}
    kept_obs = obs.copy()
    for a in np.random.default_rng(0).integers(0, 32, size=(5, 2)):
        env.step(a)
    assert np.array_equal(obs, kept_obs)
    for name in FIELDS:
        assert np.array_equal(getattr(state, name), kept[name]), name


def test_on_a_tie_the_first_user_is_strong_as_in_the_reference():
    # both users of each cluster at the same distance from the UAV: equal gains
    scenario = make_scenario(users={"positions_m": [[10.0, 0.0], [-10.0, 0.0], [0.0, 20.0],
                                                    [0.0, -20.0]]})
    env, ref = NetworkBatch(scenario, 2, seed=0), Reference(scenario, 2, 0)
    env.reset(), ref.reset()
    uav_m, alpha_first = np.array([[0.0, 0.0, 30.0], [0.0, 0.0, 60.0]]), np.full((2, 2), 0.3)
    ref.uav_m, ref.alpha_first = uav_m, alpha_first
    state = env.evaluate_at(uav_m, alpha_first)
    assert np.all(state.gain[:, 0] == state.gain[:, 1])
    _assert_same(env.observation(), state, *ref.evaluate())
