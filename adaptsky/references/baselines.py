"""The baselines that search nothing: random controls, SoA (docs/evaluation.md#baselines)
and tracking. Every rollout moves the users as the policy's does, with the same draws."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptsky.progress import Tick
from adaptsky.references.reference import Reference
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.rollout import hold, random_controls_policy, rollout
from adaptsky.rollouts.soa import ESTIMATES_NOTE, estimated_split, soa_configuration
from adaptsky.rollouts.tracking import track
from adaptsky.scenario import Scenario
from adaptsky.sim.controls import controls_of
from adaptsky.sim.network import NetworkBatch


@dataclass(frozen=True)
class RandomControls(Reference):
    """Uniformly random controls at every step."""

    any_cluster_size = True
    uplink = True

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        policy = random_controls_policy(controls_of(scenario, len(users_m)), seed)
        return Method.of(self.name, scenario,
                         rollout(scenario, policy, steps, users_m, seed, on_progress), {})


@dataclass(frozen=True)
class Soa(Reference):
    """The state of the art: each UAV planned once from its users' positions, held; its
    rates taken at each step's positions (SoA per UAV for several)."""

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        if scenario.uav.count == 1:
            env = NetworkBatch(scenario, num_envs=len(users_m), users_m=users_m)
            uav_m, alpha_first = soa_configuration(env)
        else:
            uav_m, alpha_first = several_uavs.soa_per_uav(scenario, users_m)
        if scenario.channel.csi.model == "perfect":
            trace = hold(scenario, uav_m, alpha_first, steps, users_m, seed, on_progress)
            return Method.of(self.name, scenario, trace, {})
        # imperfect channel knowledge: every step's split from the latest estimates
        one = scenario.uav.count == 1
        trace = hold(scenario, uav_m,
                     lambda env: estimated_split(env)[:, 0] if one else estimated_split(env),
                     steps, users_m, seed, on_progress)
        return Method.of(self.name, scenario, trace, {"note": ESTIMATES_NOTE})


@dataclass(frozen=True)
class Tracking(Reference):
    """SoA re-planned at every step's user positions, flown there at the UAV's speed."""

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        details = {} if scenario.channel.csi.model == "perfect" else {"note": ESTIMATES_NOTE}
        return Method.of(self.name, scenario,
                         track(scenario, steps, users_m, seed, on_progress), details)
