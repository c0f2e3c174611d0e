"""Propulsion energy (docs/model.md §10): P(V) against the check values and a scalar formula
written out from Zeng, Xu and Zhang's eq. 12 with their Table I, a step's energy, and the
reward's energy term: absent at w_e = 0 (every reward the same, bit for bit), - w_e E / (P(0)
dt) otherwise, for one UAV and for several."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.sim.energy import ZENG_2019, StepEnergy, least_power_w, propulsion_power_w
from adaptsky.sim.network import NetworkBatch
from tests.conftest import ROOT
from tests.helpers.scalar_models import scalar_power_w

SCENARIOS = ROOT / "scenarios"


@pytest.mark.parametrize(("speed", "power"), [(0.0, 168.48), (10.0, 126.02), (20.0, 178.29),
                                               (30.0, 356.28)])
def test_power_equals_the_check_values(speed, power):
    assert float(propulsion_power_w(speed)) == pytest.approx(power, abs=0.01)
    assert float(propulsion_power_w(speed)) == pytest.approx(scalar_power_w(speed), rel=1e-12)


def test_the_least_power_is_125_99_w_at_10_21_m_s():
    speeds = np.arange(0.0, 40.0, 0.001)
    power = propulsion_power_w(speeds)
    assert speeds[power.argmin()] == pytest.approx(10.21, abs=0.005)
    assert power.min() == pytest.approx(125.99, abs=0.01)
    assert ZENG_2019.blade_profile_w == pytest.approx(79.86, abs=0.01)
    assert ZENG_2019.induced_w == pytest.approx(88.63, abs=0.01)
    assert ZENG_2019.hover_induced_velocity_m_s == pytest.approx(4.03, abs=0.01)
    for v in (0.5, 4.0, 13.7, 25.0):
        assert float(propulsion_power_w(v)) == pytest.approx(scalar_power_w(v), rel=1e-12)


def test_continuous_moves_reach_the_least_power_between_hover_and_a_full_move():
    # moves up to 10 m per axis and second: the speeds reach 10.21 m/s (P = 125.99 W), which
    # no discrete move has (paper: 14.1 m/s; with hover also 0 and 10 m/s)
    powers = {}
    for actions in ("paper", "with-hover", "continuous"):
        scenario = parse_scenario({"name": "x", "uav": {"actions": actions,
                                                        "step_m": [10.0, 10.0, 1.0]}}, "x")
        transmitters_w = float(StepEnergy.of(scenario).power_w(np.zeros((1, 3)))[0]
                               - propulsion_power_w(0.0))
        powers[actions] = least_power_w(scenario) - transmitters_w
    assert powers["paper"] == pytest.approx(float(propulsion_power_w(math.sqrt(200))))
    assert powers["with-hover"] == pytest.approx(float(propulsion_power_w(10.0)))
    assert powers["continuous"] == pytest.approx(125.99, abs=0.01)


def test_a_steps_energy_counts_speed_climbing_and_transmitters():
    energy = StepEnergy(step_s=0.1, tx_power_w=0.1, clusters=2)
    moves = np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    expected = [scalar_power_w(10.0) + 0.2,
                scalar_power_w(math.sqrt(2) * 10) + 20.0 * 10 + 0.2,   # climbs 10 m/s
                scalar_power_w(0.0) + 0.2,                             # descends: no credit
                scalar_power_w(0.0) + 0.2]
    np.testing.assert_allclose(energy.power_w(moves), expected, rtol=1e-12)
    np.testing.assert_allclose(energy.energy_j(moves), np.array(expected) * 0.1, rtol=1e-12)
    assert energy.hover_step_j == pytest.approx(scalar_power_w(0.0) * 0.1, rel=1e-12)


def _rollout(scenario, steps: int = 6):
    env = NetworkBatch(scenario, num_envs=2, seed=3)
    env.reset()
    actions = np.random.default_rng(0).integers(env.actions.count, size=(steps, 2))
    return env, [env.step(a)[3] for a in actions]


@pytest.mark.parametrize("name", ["nyc_mmwave", "two_uavs_mmwave"])
def test_the_energy_term_is_off_by_default_and_minus_w_e_e_over_a_hover_step(name):
    text = (SCENARIOS / f"{name}.toml").read_text()
    base = load_scenario(SCENARIOS / f"{name}.toml")
    data = base.model_dump(mode="json")
    zero = parse_scenario({**data, "reward": {**data["reward"], "w_energy": 0.0}}, "zero")
    weighted = parse_scenario({**data, "reward": {**data["reward"], "w_energy": 2.5},
                               "uav": {**data["uav"], "step_s": 0.1}}, "weighted")
    timed = parse_scenario({**data, "uav": {**data["uav"], "step_s": 0.1}}, "timed")
    assert "w_energy" not in text
    _, plain = _rollout(base)
    _, zeroed = _rollout(zero)
    for a, b in zip(plain, zeroed, strict=True):
        assert np.array_equal(a.reward, b.reward) and np.array_equal(a.energy_j, b.energy_j)
    _, unweighted = _rollout(timed)
    env, states = _rollout(weighted)
    hover_step_j = scalar_power_w(0.0) * 0.1
    for a, b in zip(unweighted, states, strict=True):
        total = b.energy_j if b.energy_j.ndim == 1 else b.energy_j.sum(axis=-1)
        np.testing.assert_allclose(b.reward, a.reward - 2.5 * total / hover_step_j,
                                   rtol=1e-12)
        assert (b.energy_j > 0).all()
    if env.num_uavs > 1:  # each UAV's part carries its own energy
        parts = env.reward_parts(states[-1])
        np.testing.assert_allclose(parts.sum(axis=-1), states[-1].reward, rtol=1e-9)
