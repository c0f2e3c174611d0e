"""The NOMA-UAV network of docs/model.md §1-4, simulated for B independent layouts at once.

One :class:`NomaUavBatch` holds B UAVs, each serving its own layout of N users in K = N/2
clusters. All B environments step in lockstep: one call to :meth:`NomaUavBatch.step` takes B
actions and returns B rewards. Episodes end by the time limit T (a truncation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky_cli.channels.contract import ChannelModel, LinkGeometry
from adaptsky_cli.channels.registry import get_model_class
from adaptsky_cli.env import noma
from adaptsky_cli.env.actions import ActionSet
from adaptsky_cli.env.layout import pair_users, user_layouts
from adaptsky_cli.env.observation import observe
from adaptsky_cli.scenario.models import Scenario

FloatArray = NDArray[np.float64]


def build_channel(scenario: Scenario) -> ChannelModel:
    """The scenario's channel-model plugin with its parameters."""
    model_class = get_model_class(scenario.channel.model)
    return model_class(model_class.Params.model_validate(scenario.channel.params))


def deterministic_gain(channel: ChannelModel, los: str, geometry: LinkGeometry) -> FloatArray:
    """The gain planning uses: the LoS gain for ``los = "always"``, else the expected gain."""
    return channel.gain_los(geometry) if los == "always" else channel.expected_gain(geometry)


def reward_weights(scenario: Scenario) -> noma.RewardWeights:
    r = scenario.reward
    return noma.RewardWeights(w_rate=r.w_rate, w_fairness=r.w_fairness, w_gain=r.w_gain,
                              w_satisfied=r.w_satisfied, w_unsatisfied=r.w_unsatisfied,
                              min_rate_bps=scenario.min_rate_bps)


@dataclass(frozen=True)
class NetworkState:
    """The network after a reset or step; leading axis B, then users N where it applies.

    gain is the linear gain of one antenna pair used for the rates; los the LoS state of each
    link (for ``los = "expected"``: P_LoS > 0.5); p_los the LoS probability.
    """

    uav_m: FloatArray
    alpha: FloatArray
    gain: FloatArray
    los: NDArray[np.bool_]
    p_los: FloatArray
    rate_bps: FloatArray
    sum_rate_bps: FloatArray
    fairness: FloatArray
    reward: FloatArray

    def for_env(self, index: int) -> dict[str, np.ndarray | float]:
        """The state of environment ``index`` as a Gymnasium ``info`` dict."""
        return {
            "uav_m": self.uav_m[index].copy(),
            "alpha": self.alpha[index].copy(),
            "gain": self.gain[index].copy(),
            "los": self.los[index].copy(),
            "p_los": self.p_los[index].copy(),
            "rate_bps": self.rate_bps[index].copy(),
            "sum_rate_bps": float(self.sum_rate_bps[index]),
            "fairness": float(self.fairness[index]),
        }


class NomaUavBatch:
    """B independent copies of the network, vectorised with numpy.

    Arguments: ``scenario`` (validated), ``num_envs`` B, ``seed`` of the generator that draws
    LoS states and user moves, ``users_m`` (B, N, 2) to override the scenario's layouts.
    """

    def __init__(self, scenario: Scenario, num_envs: int = 1,
                 seed: int | np.random.SeedSequence | None = None,
                 users_m: FloatArray | None = None) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.scenario = scenario
        self.num_envs = num_envs
        self.num_users = scenario.num_users
        self.num_clusters = scenario.num_clusters
        self.channel = build_channel(scenario)
        self.actions = ActionSet(self.num_clusters, scenario.uav.actions)
        self.weights = reward_weights(scenario)
        radio = scenario.radio
        self.bandwidth_hz = radio.bandwidth_hz
        self.snr_scale = radio.tx_power_w * radio.antenna_gain / radio.noise_w
        if users_m is None:
            users_m = user_layouts(scenario, num_envs)
        if users_m.shape != (num_envs, self.num_users, 2):
            raise ValueError(f"users_m must have shape {(num_envs, self.num_users, 2)}, "
                             f"got {users_m.shape}")
        self.layouts_m = np.array(users_m, dtype=np.float64)
        uav = scenario.uav
        self._start_m = np.array(uav.start_m, dtype=np.float64)
        self._step_m = np.array(uav.step_m, dtype=np.float64)
        half_m = scenario.area.side_m / 2
        self._low_m = np.array([-half_m, -half_m, uav.min_height_m])
        self._high_m = np.array([half_m, half_m, uav.max_height_m])
        start_uav = np.broadcast_to(self._start_m, (num_envs, 3))
        start_gain = deterministic_gain(self.channel, scenario.channel.los,
                                        LinkGeometry.between(start_uav, self.layouts_m))
        self.first_user, self.second_user = pair_users(start_gain, scenario.users.pairing)
        # flat positions of (first users, second users) in a (B, N) array, for fast gathers
        rows = np.arange(num_envs)[:, None] * self.num_users
        self._cluster_flat = (rows + np.concatenate([self.first_user, self.second_user],
                                                    axis=1)).ravel()
        self.rng = np.random.default_rng(seed)
        self._to_start()
        self.state: NetworkState | None = None

    @property
    def max_steps(self) -> int:
        return self.scenario.train.steps

    def _link_gains(self, geometry: LinkGeometry) -> tuple[FloatArray, NDArray[np.bool_],
                                                           FloatArray]:
        """Gain, LoS state and LoS probability of every link under the scenario's LoS mode."""
        p_los = self.channel.los_probability(geometry)
        mode = self.scenario.channel.los
        if mode == "always":
            return self.channel.gain_los(geometry), np.ones(geometry.shape, dtype=bool), p_los
        if mode == "sampled":
            los = self.channel.sample_los(geometry, self.rng)
            gain = np.where(los, self.channel.gain_los(geometry), self.channel.gain_nlos(geometry))
            return gain, los, p_los
        return self.channel.expected_gain(geometry), p_los > 0.5, p_los

    def _to_users(self, first: FloatArray, second: FloatArray) -> FloatArray:
        """(B, N) array from the values of every cluster's first and second users (B, K)."""
        values = np.empty(self.num_envs * self.num_users)
        values[self._cluster_flat] = np.concatenate([first, second], axis=1).ravel()
        return values.reshape(self.num_envs, self.num_users)

    def per_user_alpha(self, alpha_first: FloatArray) -> FloatArray:
        """alpha (B, N) of every user from the first users' shares (B, K)."""
        return self._to_users(alpha_first, 1.0 - alpha_first)

    def _evaluate(self) -> NetworkState:
        geometry = LinkGeometry.between(self.uav_m, self.users_m)
        gain, los, p_los = self._link_gains(geometry)
        clustered = gain.ravel()[self._cluster_flat].reshape(self.num_envs, self.num_users)
        k = self.num_clusters
        sinr_first, sinr_second = noma.cluster_sinr(self.alpha_first, clustered[:, :k],
                                                    clustered[:, k:], self.snr_scale)
        rates = self._to_users(noma.rate_bps(sinr_first, self.bandwidth_hz),
                               noma.rate_bps(sinr_second, self.bandwidth_hz))
        fairness = noma.jain_fairness(rates)
        rewards = noma.reward(rates, gain, fairness, self.bandwidth_hz, self.weights)
        return NetworkState(uav_m=self.uav_m.copy(), alpha=self.per_user_alpha(self.alpha_first),
                            gain=gain, los=los, p_los=p_los, rate_bps=rates,
                            sum_rate_bps=rates.sum(axis=1), fairness=fairness, reward=rewards)

    def evaluate_at(self, uav_m: FloatArray, alpha_first: FloatArray) -> NetworkState:
        """The network with every UAV at ``uav_m`` (B, 3) and first users' shares
        ``alpha_first`` (B, K), taken as given (no clipping); LoS is drawn as in a step.
        Baselines use this to hold a configuration."""
        self.uav_m = np.array(uav_m, dtype=np.float64)
        self.alpha_first = np.array(alpha_first, dtype=np.float64)
        self.state = self._evaluate()
        return self.state

    def observation(self) -> NDArray[np.float32]:
        assert self.state is not None, "call reset() first"
        return observe(self.scenario, self.uav_m, self.users_m, self.state.alpha,
                       self.state.gain)

    def reset(self, seed: int | None = None) -> tuple[NDArray[np.float32], NetworkState]:
        """Start an episode: UAV at ``uav.start_m``, every alpha at ``start_alpha``
        (docs/model.md §3).

        A ``seed`` re-seeds the generator of LoS draws and user moves.
        """
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self._to_start()
        self.state = self._evaluate()
        return self.observation(), self.state

    def _to_start(self) -> None:
        """Step 0: UAV at the start, first users' shares at start_alpha, users at home."""
        self.t = 0
        self.uav_m = np.broadcast_to(self._start_m, (self.num_envs, 3)).copy()
        self.users_m = self.layouts_m.copy()
        self.alpha_first = np.full((self.num_envs, self.num_clusters),
                                   self.scenario.uav.start_alpha)

    def _move_users(self) -> None:
        speed = self.scenario.users.speed_m_per_step
        if speed == 0:
            return
        heading = self.rng.uniform(0.0, 2 * np.pi, size=(self.num_envs, self.num_users))
        step = speed * np.stack([np.cos(heading), np.sin(heading)], axis=-1)
        half_m = self.scenario.area.side_m / 2
        self.users_m = np.clip(self.users_m + step, -half_m, half_m)

    def apply(self, actions: NDArray[np.integer]) -> None:
        """Move every UAV and change every alpha by its action, clipped to the feasible set.

        Feasible set (alg. 1 line 7): |x|, |y| <= L/2, h_min <= h <= h_max,
        power_step <= alpha <= 1 - power_step.
        """
        actions = np.asarray(actions)
        if actions.shape != (self.num_envs,):
            raise ValueError(f"expected {self.num_envs} actions, got shape {actions.shape}")
        if not (actions.min() >= 0 and actions.max() < self.actions.count):
            raise ValueError(f"actions must lie in [0, {self.actions.count})")
        directions = self.actions.decode(actions)
        moved_m = self.uav_m + directions[:, :3] * self._step_m
        self.uav_m = np.minimum(np.maximum(moved_m, self._low_m), self._high_m)
        power_step = self.scenario.uav.power_step
        alpha = self.alpha_first + directions[:, 3:] * power_step
        self.alpha_first = np.minimum(np.maximum(alpha, power_step), 1.0 - power_step)

    def step(self, actions: NDArray[np.integer]
             ) -> tuple[NDArray[np.float32], FloatArray, bool, NetworkState]:
        """Apply B actions; return observations, rewards (eq. 13), truncated, and the state.

        The reward and next observation use the channel at the position after the move
        (the released code's one-step lag is not copied, docs/model.md §7).
        """
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        self.apply(actions)
        self._move_users()
        self.t += 1
        self.state = self._evaluate()
        return self.observation(), self.state.reward, self.t >= self.max_steps, self.state
