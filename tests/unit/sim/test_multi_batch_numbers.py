"""NetworkBatch's step gives, bit for bit, the numbers of a straightforward computation from
the pure functions of docs/model.md §9 (links, interference, NOMA, the separation rule, the
observation), however the step is made fast (index arrays made once per layout, buffers kept,
the separation tested cheaply first). The reference here recomputes everything every step,
drawing from generators of its own seeded alike."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from adaptsky.channels.contract import ChannelModel, LinkGeometry
from adaptsky.envs.observations import AgentView, user_order_of, users_in_order
from adaptsky.scenario import Scenario, load_scenario
from adaptsky.sim import noma
from adaptsky.sim.links import build_channel, carrier_hz, link_gains, links_geometry
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.observation import GAIN_DB_CENTER, GAIN_DB_SCALE
from adaptsky.sim.reward import reward_weights
from adaptsky.sim.state import Dynamics, SimState, step
from tests.helpers.rates_reference import noma_rates

NUM_ENVS = 12
STEPS = 200
FIELDS = ("uav_m", "alpha", "gain", "interference_w", "los", "p_los", "strong", "rate_bps",
          "sum_rate_bps", "fairness", "reward")


def reference_separated(uav_m: np.ndarray, moved_m: np.ndarray, min_m: float) -> np.ndarray:
    """The separation rule of docs/model.md §9, the plain way: hold back both UAVs of every
    pair that ends closer than ``min_m`` and closer than it was, until no such pair is left."""
    def distances(positions: np.ndarray) -> np.ndarray:
        delta = positions[:, :, None, :2] - positions[:, None, :, :2]
        return np.hypot(delta[..., 0], delta[..., 1])

    before = distances(uav_m)
    others = ~np.eye(uav_m.shape[1], dtype=bool)
    held = np.zeros(uav_m.shape[:2], dtype=bool)
    result = moved_m
    for _ in range(uav_m.shape[1]):
        after = distances(result)
        blocked = ((after < min_m) & (after < before) & others).any(axis=2) & ~held
        if not blocked.any():
            break
        held |= blocked
        result = np.where(held[..., None], uav_m, moved_m)
    return result


def reference_observation(scenario: Scenario, uav_m: np.ndarray, users_m: np.ndarray,
                          serving: np.ndarray, alpha: np.ndarray, gain: np.ndarray,
                          interference: np.ndarray, order: np.ndarray | None
                          ) -> NDArray[np.float32]:
    """[x_u - x_i, y_u - y_i, alpha_i, g_i, I_i] per user, then [x_u, y_u, h_u] per UAV,
    scaled as docs/environment.md says, in float64 and rounded to float32 at the end."""
    num_envs, n = gain.shape
    serving_m = np.take_along_axis(uav_m, serving[..., None], axis=1)
    features = np.empty((num_envs, n, 5))
    features[..., :2] = serving_m[..., :2] - users_m
    features[..., 2] = alpha
    inr = interference / scenario.radio.noise_w
    uavs = np.array(uav_m, dtype=np.float64)
    if scenario.agent.observation == "scaled":
        half = scenario.area.side_m / 2
        features[..., :2] /= half
        features[..., 3] = (10.0 * np.log10(gain) - GAIN_DB_CENTER) / GAIN_DB_SCALE
        features[..., 4] = 10.0 * np.log10(1.0 + inr) / GAIN_DB_SCALE
        uavs[..., :2] /= half
        uavs[..., 2] /= scenario.uav.max_height_m
    else:
        features[..., 3] = gain
        features[..., 4] = inr
    if order is not None:
        features = np.take_along_axis(features, order[..., None], axis=1)
    return np.concatenate([features.reshape(num_envs, -1), uavs.reshape(num_envs, -1)],
                          axis=1).astype(np.float32)


def plain_draws(channel: ChannelModel) -> ChannelModel:
    """``channel`` whose ``sample_los`` is its own override (calling the base class's), so
    that ``link_gains`` asks it for every environment's draws on a geometry of that
    environment's rows, the plain way, rather than drawing the uniforms itself."""
    class PlainDraws(type(channel)):  # type: ignore[misc,valid-type]
        def sample_los(self, geometry: LinkGeometry, rng: np.random.Generator
                       ) -> np.ndarray:
            return super().sample_los(geometry, rng)

    return PlainDraws(channel.params)


class Reference:
    """The network of ``env``'s scenario and association, stepped the plain way."""

    def __init__(self, env: NetworkBatch, seeds: list[np.random.SeedSequence]) -> None:
        self.scenario, self.env = env.scenario, env
        self.channel = plain_draws(build_channel(env.scenario))
        self.dynamics = Dynamics.of(env.scenario, env.num_envs)
        self.rngs = [np.random.default_rng(seed) for seed in seeds]
        start = np.broadcast_to(env.start_m, (env.num_envs, *env.start_m.shape))
        alpha = np.full((env.num_envs, env.num_uavs, env.num_clusters),
                        env.scenario.uav.start_alpha)
        self.state = SimState.of(start, alpha, env.layouts_m)
        self.held_steps = 0     # steps in which the separation held a UAV back

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        scenario, before = self.scenario, self.state
        headings = None
        if scenario.users.speed_m_per_step:
            headings = np.stack([rng.uniform(0.0, 2 * np.pi, size=scenario.num_users)
                                 for rng in self.rngs])
        moved = step(before, actions, self.dynamics, headings)
        positions = reference_separated(before.uav_m, moved.config[..., :3],
                                        scenario.uav.min_separation_m)
        config = np.concatenate([positions, moved.config[..., 3:]], axis=-1)
        self.held_steps += int(np.any(positions != moved.config[..., :3]))
        self.state = SimState(config, moved.users_m, moved.t)
        return self.evaluate()

    def evaluate(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        scenario, env, state = self.scenario, self.env, self.state
        radio = scenario.radio
        geometry = links_geometry(state.uav_m, state.users_m,
                                      user_height_m=scenario.users.height_m,
                                      carrier_hz=carrier_hz(scenario),
                                      bandwidth_hz=radio.bandwidth_hz)
        gains, los, p_los = link_gains(self.channel, scenario.channel.los, geometry, self.rngs,
                                       num_uavs=env.num_uavs)
        association = env.association
        rates = noma_rates(state.alpha_first, gains, association, tx_power_w=radio.tx_power_w,
                           antenna_gain=radio.antenna_gain, noise_w=radio.noise_w,
                           bandwidth_hz=radio.bandwidth_hz, reuse=radio.reuse)
        serving = association.serving_uav
        rows = np.arange(env.num_envs)[:, None]
        alpha_k = state.alpha_first[rows, serving, association.cluster]
        alpha = np.where(association.is_first, alpha_k, 1.0 - alpha_k)
        fairness = noma.jain_fairness(rates.rate_bps)
        numbers = {
            "uav_m": state.uav_m, "alpha": alpha, "gain": rates.gain,
            "interference_w": rates.interference_w,
            "los": np.take_along_axis(los, serving[:, None, :], axis=1)[:, 0],
            "p_los": np.take_along_axis(p_los, serving[:, None, :], axis=1)[:, 0],
            "strong": rates.strong, "rate_bps": rates.rate_bps,
            "sum_rate_bps": rates.rate_bps.sum(axis=-1), "fairness": fairness,
            "reward": noma.reward(rates.rate_bps, rates.gain, fairness, radio.bandwidth_hz,
                                  reward_weights(scenario))}
        order = users_in_order(association, user_order_of(scenario))
        obs = reference_observation(scenario, state.uav_m, state.users_m, serving, alpha,
                                    rates.gain, rates.interference_w, order)
        return obs, numbers


def variant(name: str, kind: str) -> Scenario:
    scenario = load_scenario(f"scenarios/{name}.toml")
    if kind == "shipped":
        return scenario
    if kind == "sampled-moving-raw":
        return scenario.model_copy(update={
            "channel": scenario.channel.model_copy(update={"los": "sampled"}),
            "users": scenario.users.model_copy(update={"speed_m_per_step": 1.5}),
            "agent": scenario.agent.model_copy(update={"user_order": "listed",
                                                       "observation": "raw"})})
    if kind == "expected-orthogonal-raised":   # user antennas 1.5 m above the ground
        return scenario.model_copy(update={
            "channel": scenario.channel.model_copy(update={"los": "expected"}),
            "users": scenario.users.model_copy(update={"height_m": 1.5}),
            "radio": scenario.radio.model_copy(update={"reuse": "orthogonal"})})
    assert kind == "close"   # UAVs 12 m apart: the separation holds moves back
    starts = [[12.0 * u, 3.0 * (u % 2), 50.0] for u in range(scenario.uav.count)]
    return scenario.model_copy(update={"uav": scenario.uav.model_copy(
        update={"start_positions_m": starts})})


def same(a: np.ndarray, b: np.ndarray) -> bool:
    """Bit for bit: dtype, shape and bytes."""
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("kind", ["shipped", "sampled-moving-raw", "expected-orthogonal-raised",
                                  "close"])
@pytest.mark.parametrize("name", ["two_uavs_mmwave", "four_uavs_mmwave", "eight_uavs_mmwave"])
def test_step_equals_the_plain_computation(name: str, kind: str) -> None:
    scenario = variant(name, kind)
    seeds = [np.random.SeedSequence([s, 0]) for s in range(NUM_ENVS)]
    env = NetworkBatch(scenario, NUM_ENVS, seed=seeds, view=AgentView.of(scenario))
    reference = Reference(env, seeds)
    obs, state = env.reset()
    expected_obs, expected = reference.evaluate()
    actions = np.random.default_rng(1).integers(0, env.actions.count, size=(STEPS, NUM_ENVS))
    for t in range(STEPS + 1):
        assert same(obs, expected_obs), f"observation differs at step {t}"
        for field in FIELDS:
            assert same(getattr(state, field), expected[field]), f"{field} differs at step {t}"
        if t == STEPS:
            break
        obs, reward, _, state = env.step(actions[t])
        assert same(reward, state.reward)
        expected_obs, expected = reference.step(actions[t])
    if kind == "close":
        assert reference.held_steps > 0, "the separation never held a UAV back"
