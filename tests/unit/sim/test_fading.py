"""Built-in small-scale fading (issue 37, docs/model.md §11): the distributions of |h|^2
against the exact ones (scipy), the K-factor of the elevation against the scalar formula and
against the K fitted from the moments of |h|^2, the correlation of the scattered part, NLoS
and interfering links, draws that do not depend on B, common random numbers for held
configurations, and fading off leaving the gains as they were.

Every statistical check uses a fixed seed (so none is flaky) and states its tolerance: a few
standard errors of the estimate at its sample size, or a KS p-value above 0.01.
"""

from __future__ import annotations

import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from scipy import stats

from adaptsky.envs.gym_env import NomaUavEnv
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from adaptsky.scenario.models import Fading
from adaptsky.sim.fading import BLOCK_UNIFORMS, FadingStage, block_steps, k_factor
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SUB6_RADIO, make_scenario

SAMPLES_ENVS = 2000        # environments of a FadingStage in the distribution tests
KS_P_MIN = 0.01            # a KS test passes above this p-value (fixed seeds: deterministic)


def spec_power_gain(s: np.ndarray, k: np.ndarray | float) -> np.ndarray:
    """|h|^2 straight from docs/model.md eq. 11.1: h = sqrt(K/(K+1)) + sqrt(1/(K+1)) s."""
    h = np.sqrt(k / (k + 1)) + np.sqrt(1 / (k + 1)) * s
    return np.abs(h) ** 2


def spec_k_factor(theta_rad: float, k0_db: float, k90_db: float) -> float:
    """Eq. 11.2 as a scalar: K0 exp((2/pi) ln(K90/K0) theta), K0 and K90 linear."""
    k0, k90 = 10 ** (k0_db / 10), 10 ** (k90_db / 10)
    return k0 * math.exp((2 / math.pi) * math.log(k90 / k0) * theta_rad)


def gains_at(elevation_deg: float, model: str = "rician", steps: int = 20, correlation=None,
             los: bool = True, seed: int = 0, **keys: float) -> np.ndarray:
    """|h|^2 of SAMPLES_ENVS x 4 links at one elevation over ``steps`` steps (every sample)."""
    fading = Fading(model=model, correlation=correlation, **keys)
    stage = FadingStage(fading, SAMPLES_ENVS, 1, 4)
    elevation = np.full((SAMPLES_ENVS, 4), float(elevation_deg))
    rng = np.random.default_rng(seed)
    mask = None if los else np.zeros(elevation.shape, dtype=bool)
    return np.concatenate([stage.power_gains(elevation, mask, rng).ravel()
                           for _ in range(steps)])


def moment_k(gains: np.ndarray) -> float:
    """The K-factor fitted from the moments of |h|^2: with gamma = Var|h|^2 / (E|h|^2)^2,
    K = sqrt(1 - gamma) / (1 - sqrt(1 - gamma)) (a Rician |h|^2 has gamma = (2K + 1)/(K + 1)^2)."""
    root = math.sqrt(1 - gains.var() / gains.mean() ** 2)
    return root / (1 - root)


# ---- the maths ------------------------------------------------------------------------------

@pytest.mark.parametrize(("k0_db", "k90_db"), [(0.0, 15.0), (-5.0, 10.0), (3.0, 3.0)])
def test_k_factor_is_the_scalar_formula_and_hits_k0_and_k90(k0_db, k90_db):
    for theta in (0.0, 0.3, 1.0, math.pi / 2):
        assert k_factor(theta, k0_db, k90_db) == pytest.approx(
            spec_k_factor(theta, k0_db, k90_db), rel=1e-12)
    assert k_factor(0.0, k0_db, k90_db) == pytest.approx(10 ** (k0_db / 10), rel=1e-12)
    assert k_factor(math.pi / 2, k0_db, k90_db) == pytest.approx(10 ** (k90_db / 10), rel=1e-12)


def test_the_stage_is_eq_11_1_of_its_scattered_part_at_every_elevation():
    """The stage's |h|^2 equals eq. 11.1 of its own s with K of eq. 11.2 (to rounding)."""
    stage = FadingStage(Fading(model="rician", k0_db=-2.0, k90_db=12.0), 3, 2, 4)
    elevation = np.linspace(0.0, 90.0, 24).reshape(6, 4)
    los = np.arange(24).reshape(6, 4) % 3 > 0
    rng = np.random.default_rng(5)
    gains = stage.power_gains(elevation, los, rng)
    twin = FadingStage(Fading(model="rician", k0_db=-2.0, k90_db=12.0), 3, 2, 4)
    parts = twin.scattered(np.random.default_rng(5)).astype(np.float64)  # the same draw
    s = (parts[0] + 1j * parts[1]).reshape(6, 4)
    k = np.where(los, [[spec_k_factor(math.radians(e), -2.0, 12.0) for e in row]
                       for row in elevation], 0.0)
    np.testing.assert_allclose(gains, spec_power_gain(s, k), rtol=1e-12)


# ---- distributions ----------------------------------------------------------------------------

@pytest.mark.parametrize(("model", "elevation_deg"), [("rayleigh", 30.0), ("rician", 0.0),
                                                      ("rician", 45.0), ("rician", 90.0)])
def test_the_mean_of_h_squared_is_one(model, elevation_deg):
    gains = gains_at(elevation_deg, model)         # 160000 samples, sd of |h|^2 <= 1
    assert abs(gains.mean() - 1) < 0.01, f"mean {gains.mean():.4f}; tolerance 0.01 (4 SE)"


def test_rayleigh_is_exp_1():
    gains = gains_at(30.0, "rayleigh", steps=3)[:20000]
    p = stats.kstest(gains, stats.expon().cdf).pvalue
    assert p > KS_P_MIN, f"KS against Exp(1): p = {p:.3g}"


@pytest.mark.parametrize("elevation_deg", [0.0, 30.0, 90.0])
def test_rician_is_the_scaled_noncentral_chi_square(elevation_deg):
    k = spec_k_factor(math.radians(elevation_deg), 0.0, 15.0)
    gains = gains_at(elevation_deg, "rician", steps=3)[:20000]
    law = stats.ncx2(df=2, nc=2 * k, scale=1 / (2 * (k + 1)))
    p = stats.kstest(gains, law.cdf).pvalue
    assert p > KS_P_MIN, f"KS against ncx2(2, 2K = {2 * k:.3g}): p = {p:.3g}"


@pytest.mark.parametrize(("elevation_deg", "k_db"), [(0.0, 0.0), (90.0, 15.0)])
def test_the_k_fitted_from_moments_is_k0_and_k90(elevation_deg, k_db):
    gains = gains_at(elevation_deg, "rician", steps=50)     # 400000 samples
    fitted_db = 10 * math.log10(moment_k(gains))
    assert abs(fitted_db - k_db) < 0.3, f"fitted K {fitted_db:.3f} dB; tolerance 0.3 dB"


def test_nlos_links_of_a_rician_stage_are_rayleigh():
    gains = gains_at(60.0, "rician", steps=3, los=False, k0_db=20.0, k90_db=20.0)[:20000]
    p = stats.kstest(gains, stats.expon().cdf).pvalue
    assert p > KS_P_MIN, f"KS of NLoS links against Exp(1): p = {p:.3g}"


def test_correlation_0_9_gives_a_lag_one_autocorrelation_of_0_9():
    stage = FadingStage(Fading(model="rician", correlation=0.9), 500, 2, 4)
    rng = np.random.default_rng(3)
    series = []
    for _ in range(200):
        parts = stage.scattered(rng)
        series.append(parts[0] + 1j * parts[1])
    s = np.array(series)                                       # (T, B, U, N)
    lag1 = np.mean(s[1:] * np.conj(s[:-1])).real / np.mean(np.abs(s) ** 2)
    # 796000 pairs: standard error about (1 - rho^2) / sqrt(n) ~ 2e-4, with the steps'
    # correlation a few times that
    assert abs(lag1 - 0.9) < 0.01, f"lag-1 autocorrelation {lag1:.4f}; tolerance 0.01"
    assert abs(np.mean(np.abs(s) ** 2) - 1) < 0.02, "E|s|^2 = 1 (tolerance 0.02)"


def test_without_correlation_successive_steps_are_independent():
    stage = FadingStage(Fading(model="rayleigh"), 500, 1, 4)
    rng = np.random.default_rng(4)
    s = np.array([(lambda p: p[0] + 1j * p[1])(stage.scattered(rng)) for _ in range(100)])
    lag1 = np.mean(s[1:] * np.conj(s[:-1])).real
    assert abs(lag1) < 0.01, f"lag-1 autocorrelation {lag1:.4f}; tolerance 0.01 (5 SE)"


# ---- the stage in the simulator ----------------------------------------------------------------

def faded(sections: dict, fading: dict | None) -> object:
    """A scenario of ``sections`` with ``channel.fading`` set to ``fading``."""
    channel = dict(sections.get("channel", {}))
    if fading is not None:
        channel["fading"] = fading
    return make_scenario(**{**sections, "channel": channel})


SUB6_SAMPLED = {"radio": SUB6_RADIO, "channel": {"model": "sub6-al-hourani", "los": "sampled"}}
TWO_UAVS = {"uav": {"count": 2, "start_positions_m": [[-25.0, 0.0, 50.0], [25.0, 0.0, 50.0]]},
            "users": {"placement": "uniform", "count": 8}}


def held_gains(scenario, steps: int, num_envs: int = 400, seed: int = 0):
    """Every step's NetworkState of ``num_envs`` environments holding the start configuration
    (the users stand), per-environment seeds."""
    env = NetworkBatch(scenario, num_envs,
                       seed=[np.random.SeedSequence([seed, b]) for b in range(num_envs)])
    env.reset()
    start = env.uav_m.copy(), env.alpha_first.copy()
    return env, [env.hold_step(*start) for _ in range(steps)]


def test_nlos_links_under_sampled_los_are_rayleigh_and_los_links_rician():
    """|h|^2 = gain / (the plugin's LoS or NLoS gain of the link): Exp(1) where NLoS,
    the scaled noncentral chi-square of the link's K where LoS."""
    scenario = faded(SUB6_SAMPLED, {"model": "rician", "k0_db": 10.0, "k90_db": 10.0})
    env, states = held_gains(scenario, steps=20)
    geometry = env.geometry(env.uav_m, env.layouts_m)
    g_los, g_nlos = env.channel.gain_los(geometry), env.channel.gain_nlos(geometry)
    los = np.array([s.los for s in states])
    ratio = np.array([s.gain for s in states]) / np.where(los, g_los, g_nlos)
    p_nlos = stats.kstest(ratio[~los][:20000], stats.expon().cdf).pvalue
    k = 10.0
    law = stats.ncx2(df=2, nc=2 * k, scale=1 / (2 * (k + 1)))
    p_los = stats.kstest(ratio[los][:20000], law.cdf).pvalue
    assert (~los).sum() > 2000 and los.sum() > 2000
    assert p_nlos > KS_P_MIN and p_los > KS_P_MIN, (p_nlos, p_los)


def test_interfering_links_fade_too():
    """Two UAVs, full reuse, Rayleigh: each user hears one interfering link, whose power
    with fading over the power without is |h|^2 ~ Exp(1)."""
    _, plain = held_gains(make_scenario(**TWO_UAVS), steps=1, num_envs=50)
    _, states = held_gains(faded(TWO_UAVS, {"model": "rayleigh"}), steps=20, num_envs=50)
    ratio = np.array([s.interference_w for s in states]) / plain[0].interference_w
    p = stats.kstest(ratio.ravel(), stats.expon().cdf).pvalue
    assert p > KS_P_MIN, f"interference ratio against Exp(1): p = {p:.3g}"


@pytest.mark.parametrize(("links", "episode_steps", "steps"), [
    (4, 300, 300), (16, 300, 100), (512, 300, 4), (4, 10**9, 512), (3000, 300, 1)])
def test_a_block_splits_an_episode_evenly_within_its_uniforms(links, episode_steps, steps):
    assert block_steps(links, episode_steps) == steps
    assert steps * 2 * links <= max(BLOCK_UNIFORMS, 2 * links)


@pytest.mark.parametrize("sections", [SUB6_SAMPLED, TWO_UAVS])
def test_draws_do_not_depend_on_b(sections):
    # 30 steps an episode: blocks of 30 steps, so that 80 steps cross two block boundaries
    scenario = faded({**sections, "train": {"steps": 30}},
                     {"model": "rician", "correlation": 0.5})
    envs = [NetworkBatch(scenario, b, seed=[np.random.SeedSequence([7, i]) for i in range(b)])
            for b in (3, 5)]
    actions = np.random.default_rng(0).integers(0, envs[0].actions.count, size=(80, 5))
    for env in envs:
        env.reset()
    assert envs[0]._small_scale.block_steps == 30
    for step in range(80):
        small, large = (env.step(actions[step, :env.num_envs])[3] for env in envs)
        np.testing.assert_array_equal(small.gain, large.gain[:3])
        np.testing.assert_array_equal(small.interference_w, large.interference_w[:3])


def test_a_held_configuration_sees_the_policys_own_fading_draws():
    """Common random numbers: an environment that holds, step by step, where a policy's
    environment (same seed) went gets the policy's gains bit for bit."""
    scenario = faded({**SUB6_SAMPLED, "train": {"steps": 30}},       # blocks of 30 steps
                     {"model": "rician", "correlation": 0.9})
    policy, held = (NetworkBatch(scenario, 4, seed=11) for _ in range(2))
    policy.reset()
    held.reset()
    actions = np.random.default_rng(1).integers(0, policy.actions.count, size=(70, 4))
    for step in range(70):
        state = policy.step(actions[step])[3]
        np.testing.assert_array_equal(
            held.hold_step(policy.uav_m, policy.alpha_first).gain, state.gain)


def test_fading_off_leaves_the_gains_as_they_were():
    """Model 'none' builds no stage and draws nothing: every link's gain is the plugin's LoS
    gain, and the generator is untouched by the channel stage."""
    env = NetworkBatch(make_scenario(), 3, seed=2)
    assert env._small_scale is None
    before = env.rng.bit_generator.state
    state = env.reset()[1]
    geometry = env.geometry(env.uav_m, env.layouts_m)
    np.testing.assert_array_equal(state.gain, env.channel.gain_los(geometry))
    assert env.rng.bit_generator.state == before
    assert env.gain_bounds() is not None


def test_built_in_fading_has_no_gain_bounds_and_the_envs_pass_their_checks():
    scenario = faded({}, {"model": "rician", "correlation": 0.5})
    assert NetworkBatch(scenario, 1).gain_bounds() is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(NomaUavEnv(scenario), skip_render_check=True)
    from pettingzoo.test import parallel_api_test

    parallel_api_test(NomaUavParallelEnv(faded(TWO_UAVS, {"model": "rayleigh"})),
                      num_cycles=5)
    env = gymnasium.make("adaptsky/NomaUav-v0", scenario=scenario)
    first = env.reset(seed=3)[1]["gain"]
    assert np.array_equal(env.reset(seed=3)[1]["gain"], first)   # seeded: reproducible


@pytest.mark.parametrize("fading", [{"model": "rayleigh"}, {"model": "rician"},
                                    {"model": "rician", "correlation": 0.5}])
def test_faded_gains_stay_double_precision(fading):
    state = NetworkBatch(faded({}, fading), 2, seed=0).reset()[1]
    assert state.gain.dtype == np.float64
