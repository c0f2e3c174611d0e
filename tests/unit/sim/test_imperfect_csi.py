"""Imperfect channel knowledge (docs/model.md §16): the estimate's statistics (fixed seeds,
stated tolerances), the SIC order by the estimate and its rule (a member that must remove a
truly stronger member's message decodes nothing), the order by the truth leaving every rate
as it is, and the scenario's refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptsky.scenario.models import Csi
from adaptsky.sim import noma
from adaptsky.sim.csi import CsiStage
from adaptsky.sim.interference import sic_rates
from adaptsky.sim.network import NetworkBatch
from tests.conftest import ROOT, make_scenario
from tests.helpers.cli import refusal_of_scenario

DRAWS = 200_000


def test_the_estimate_has_the_documented_mean_and_variance():
    """g_hat = |sqrt(g) + e|^2, e ~ CN(0, s2), s2 = nmse L: E g_hat = g + s2 and
    Var g_hat = 2 g s2 + s2^2. Tolerance: 6 standard errors of the sample mean and variance
    over 200,000 draws (seed 0)."""
    stage = CsiStage(Csi(model="gaussian", nmse_db=-3.0))
    gain = np.array([[[2e-9, 5e-10, 1e-8]]])
    large = np.array([[[4e-9, 5e-10, 2e-8]]])          # the mean gain where fading acts
    rng = np.random.default_rng(0)
    draws = np.concatenate([stage.estimate(np.repeat(gain, 1000, 0), np.repeat(large, 1000, 0),
                                           rng)[:, 0] for _ in range(DRAWS // 1000)])
    s2 = 10 ** -0.3 * large[0, 0]
    g = gain[0, 0]
    mean, variance = g + s2, 2 * g * s2 + s2**2
    assert draws.shape == (DRAWS, 3)
    fourth = np.mean((draws - mean) ** 4, axis=0)             # for the variance's error
    assert np.all(np.abs(draws.mean(axis=0) - mean) < 6 * np.sqrt(variance / DRAWS))
    assert np.all(np.abs(draws.var(axis=0) - variance)
                  < 6 * np.sqrt((fourth - variance**2) / DRAWS))


def test_the_errors_are_independent_across_links_and_steps():
    """The normalised errors of two links, and of one link at two successive steps, are
    uncorrelated: |correlation| below 6 / sqrt(n) over n = 200,000 pairs (seed 1)."""
    stage = CsiStage(Csi(model="gaussian", nmse_db=0.0))
    gain = np.full((DRAWS, 1, 2), 1e-9)
    rng = np.random.default_rng(1)
    first, second = stage.estimate(gain, gain, rng), stage.estimate(gain, gain, rng)
    bound = 6 / math.sqrt(DRAWS)
    assert abs(np.corrcoef(first[:, 0, 0], first[:, 0, 1])[0, 1]) < bound
    assert abs(np.corrcoef(first[:, 0, 0], second[:, 0, 0])[0, 1]) < bound


def test_each_environment_draws_from_its_own_generator():
    """With a generator per environment, an environment's estimates do not depend on its
    neighbours: the first of three equals the same seed alone, bit for bit."""
    stage = CsiStage(Csi(model="gaussian", nmse_db=-10.0))
    gain = np.array([[[1e-9, 2e-9]], [[3e-9, 4e-9]], [[5e-9, 6e-9]]])
    together = stage.estimate(gain, gain, [np.random.default_rng(s) for s in (7, 8, 9)])
    alone = stage.estimate(gain[:1], gain[:1], [np.random.default_rng(7)])
    assert np.array_equal(together[:1], alone)


def _pair_rates(gain, gain_hat, alpha_first=0.3, residual=0.0):
    """sic_rates of one pair (users 0 and 1, user 0 first) with the order by ``gain_hat``."""
    gain, gain_hat = np.array([gain]), np.array([gain_hat])
    return sic_rates(gain, None, np.array([[alpha_first, alpha_first]]),
                     np.array([[True, False]]), lambda values: values[..., ::-1],
                     power_w=6.4, noise_w=1e-12, bandwidth_hz=1.0, sic_residual=residual,
                     estimate=(gain_hat, None))


def test_a_wrong_order_costs_the_estimated_strong_user_everything():
    """The estimate ranks user 0 stronger, the truth user 1: user 0 must decode user 1's
    message first and cannot, so it decodes nothing; user 1, the weak one by the estimate,
    decodes its own with user 0's share as interference (eq. 2's weak user, true gain)."""
    s = 6.4 / 1e-12
    rate, strong, _ = _pair_rates([1e-9, 2e-9], [3e-9, 1e-9])
    assert strong[0].tolist() == [True, False]
    assert rate[0, 0] == 0.0
    assert rate[0, 1] == pytest.approx(math.log2(1 + 0.7 * s * 2e-9 / (0.3 * s * 2e-9 + 1)),
                                       rel=1e-14)
    # the right order: the rates of perfect knowledge, bit for bit
    right, _, _ = _pair_rates([2e-9, 1e-9], [3e-9, 1e-9], residual=0.1)
    perfect = sic_rates(np.array([[2e-9, 1e-9]]), None, np.array([[0.3, 0.3]]),
                        np.array([[True, False]]), lambda values: values[..., ::-1],
                        power_w=6.4, noise_w=1e-12, bandwidth_hz=1.0, sic_residual=0.1)[0]
    assert np.array_equal(right, perfect)


def test_a_chain_member_fails_where_a_member_it_removes_is_truly_stronger():
    effective = np.array([[3.0, 1.0, 2.0]])
    # order by an estimate: member 1 first (strongest), then 0, then 2
    order = np.array([[1, 0, 2]])
    # member 1 must remove 0 and 2, both truly stronger: fails; member 0 removes 2 (weaker):
    # decodes; member 2 removes nothing
    assert noma.undecodable(effective, order).tolist() == [[False, True, False]]
    assert not noma.undecodable(effective, noma.sic_order(effective, effective)).any()


@pytest.mark.parametrize("size", [2, 3])
def test_the_order_by_the_truth_keeps_every_rate(size):
    """order_on = "truth": the estimate reaches the observation only; rates, shares and the
    order equal perfect knowledge's, bit for bit, while the observed gains differ."""
    users = {"count": 6, "placement": "uniform", "cluster_size": size}
    perfect = NetworkBatch(make_scenario(users=users), num_envs=2, seed=[3, 4])
    known = NetworkBatch(make_scenario(users=users, channel={"csi": {
        "model": "gaussian", "nmse_db": -5.0, "order_on": "truth"}}), num_envs=2, seed=[3, 4])
    obs_p, state_p = perfect.reset()
    obs_k, state_k = known.reset()
    for _ in range(3):
        action = np.array([5, 9])
        obs_p, _, _, state_p = perfect.step(action)
        obs_k, _, _, state_k = known.step(action)
    assert np.array_equal(state_p.rate_bps, state_k.rate_bps)
    assert np.array_equal(state_p.strong, state_k.strong)
    assert np.array_equal(obs_p[:, 2::4], obs_k[:, 2::4])       # the shares
    assert not np.array_equal(obs_p[:, 3::4], obs_k[:, 3::4])   # the gains: estimated


def test_the_order_by_the_estimate_loses_rate_on_average():
    """At NMSE 0 dB the estimate often reverses a pair: over 200 steps of 8 layouts the
    sum rate falls below perfect knowledge's, and some strong users by the estimate get
    rate 0 (seed 5)."""
    users = {"count": 4, "placement": "uniform"}
    perfect = NetworkBatch(make_scenario(users=users), num_envs=8, seed=5)
    known = NetworkBatch(make_scenario(users=users, channel={"csi": {
        "model": "gaussian", "nmse_db": 0.0}}), num_envs=8, seed=5)
    perfect.reset()
    known.reset()
    total_p = total_k = zeros = 0.0
    for _ in range(200):
        action = np.zeros(8, dtype=np.int64)
        total_p += perfect.step(action)[3].sum_rate_bps.sum()
        state = known.step(action)[3]
        total_k += state.sum_rate_bps.sum()
        zeros += np.sum(state.strong & (state.rate_bps == 0))
    assert total_k < 0.99 * total_p
    assert zeros > 0


@pytest.mark.parametrize(("csi", "words"), [
    ('model = "perfect"\nnmse_db = -10', "channel.csi: nmse_db given with model = 'perfect', "
                                         "which reads none of them"),
    ('model = "gaussian"', "channel.csi: model = 'gaussian' needs nmse_db"),
    ('model = "gaussian"\nnmse_db = 20', "channel.csi.nmse_db: Input should be less than or "
                                         "equal to 10"),
])
def test_csi_keys_are_checked_in_one_line(tmp_path, capsys, csi, words):
    assert words in refusal_of_scenario(tmp_path, capsys, f"[channel.csi]\n{csi}")


def scalar_soa_shares(scenario, g_hat, pairs):
    """Every user's share (N,) by SoA's split of docs/model.md §6 on the gains ``g_hat`` (N,),
    with scalars: alpha_w = min(1, (2^R - 1) / 2^R (1 + sigma^2 / (P_T G g_w))) for the weak
    user of each pair, the rest for the strong one."""
    radio, threshold = scenario.radio, 2.0 ** scenario.reward.min_se
    shares = [0.0] * len(g_hat)
    for i, j in pairs:
        weak, strong = (i, j) if g_hat[i] < g_hat[j] else (j, i)
        alpha_weak = min(1.0, (threshold - 1) / threshold * (
            1 + radio.noise_w / (radio.tx_power_w * radio.antenna_gain * g_hat[weak])))
        shares[weak], shares[strong] = alpha_weak, 1.0 - alpha_weak
    return shares


@pytest.mark.parametrize("method", ["soa", "tracking"])
def test_soa_and_tracking_split_on_the_latest_estimates(method):
    """Under imperfect knowledge SoA and tracking decide on g_hat (docs/model.md §16): every
    step's split is SoA's of §6 (scalars) on the estimates the environment drew the step
    before, replayed in a twin environment with the same seed; with perfect knowledge SoA's
    split is held as planned."""
    from adaptsky.references.registry import run_baseline
    from adaptsky.scenario import load_scenario
    from adaptsky.scenario.variants import with_values

    scenario = with_values(load_scenario(ROOT / "scenarios" / "imperfect_csi_sub6.toml"),
                           "reward", {"min_se": 0.5}, "test")
    layouts = np.asarray(scenario.users.positions_m)[None]
    found = run_baseline(scenario, method, 12, layouts)
    assert "estimates" in found.details["note"]
    twin = NetworkBatch(scenario, seed=0, users_m=layouts)
    twin.reset()
    pairs = list(zip(twin.first_user[0], twin.second_user[0], strict=True))
    for step in range(12):
        g_hat = twin.estimated_gains[0, 0]
        assert not np.allclose(g_hat, twin.state.gain[0], rtol=1e-3, atol=0)   # not the truth
        expected = scalar_soa_shares(scenario, g_hat, pairs)
        np.testing.assert_allclose(found.trace.alpha[step, 0], expected, rtol=1e-12)
        twin.fly_step(found.trace.uav_m[step], found.trace.alpha[step][:, [i for i, _ in pairs]])
    assert np.ptp(found.trace.alpha[:, 0], axis=0).max() > 0    # decided anew at each step
    perfect = with_values(scenario, "channel", {"csi": {"model": "perfect"}}, "test")
    held = run_baseline(perfect, "soa", 12, layouts).trace.alpha[:, 0]
    assert np.ptp(held, axis=0).max() == 0
