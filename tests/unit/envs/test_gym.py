"""Gymnasium API: registration, check_env, render modes, the default scenario, determinism,
the native vector env (per-environment seeds, info masks)."""

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import adaptsky  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky import shipped_files
from adaptsky.envs.gym_env import NomaUavEnv, NomaUavVectorEnv
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario
from tests.conftest import SCENARIOS, SUB6_RADIO, TRAINING_LAYOUT_M, make_scenario

ENV_ID = "adaptsky/NomaUav-v0"

INFO_SHAPES = {"uav_m": (3,), "alpha": (4,), "gain": (4,), "los": (4,), "rate_bps": (4,)}


def test_make_by_id_with_a_scenario_path():
    env = gymnasium.make("adaptsky/NomaUav-v0", scenario=str(SCENARIOS / "nyc_mmwave.toml"))
    obs, info = env.reset(seed=0)
    assert obs.shape == (17,)
    assert env.action_space.n == 32
    _, reward, terminated, truncated, info = env.step(0)
    for key, shape in INFO_SHAPES.items():
        assert np.shape(info[key]) == shape
    assert info["los"].dtype == bool
    assert isinstance(info["sum_rate_bps"], float) and isinstance(info["fairness"], float)
    assert info["sum_rate_bps"] == pytest.approx(info["rate_bps"].sum())
    assert reward == pytest.approx(10 * info["sum_rate_bps"] / 2e9)    # w_rate 10, R_min 0
    assert not terminated and not truncated


@pytest.mark.parametrize("los", ["always", "sampled", "expected"])
def test_check_env(los):
    scenario = make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani", "los": los},
                             train={"steps": 20})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning: the bounds are finite (docs/environment.md)
        # through make, so that check_env also tries the other render modes (with a spec)
        check_env(gymnasium.make(ENV_ID, scenario=scenario, render_mode="ansi").unwrapped)


def _rollout(env, seed, steps=25):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    trace = [obs]
    for _ in range(steps):
        obs, reward, _, _, info = env.step(env.action_space.sample())
        trace += [obs, np.array([reward]), info["gain"]]
    return np.concatenate([np.ravel(t) for t in trace])


def test_two_envs_same_seed_identical_rollouts():
    scenario = make_scenario(radio=SUB6_RADIO,
                             channel={"model": "sub6-al-hourani", "los": "sampled"})
    first = _rollout(NomaUavEnv(scenario), seed=3)
    second = _rollout(NomaUavEnv(scenario), seed=3)
    assert np.array_equal(first, second)
    assert not np.array_equal(first, _rollout(NomaUavEnv(scenario), seed=4))


def test_stepping_past_the_time_limit_needs_a_reset():
    env = NomaUavEnv(make_scenario(train={"steps": 2}))
    env.reset(seed=0)
    assert env.step(0)[3] is False and env.step(0)[3] is True
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)


def test_vector_env_over_uniform_layouts_autoresets_next_step():
    scenario = make_scenario(users={"positions_m": None, "count": 4}, train={"steps": 2})
    env = gymnasium.make_vec("adaptsky/NomaUav-v0", num_envs=6,
                             vectorization_mode="vector_entry_point", scenario=scenario)
    assert isinstance(env, NomaUavVectorEnv)
    obs, info = env.reset(seed=0)
    assert obs.shape == (6, 17) and info["rate_bps"].shape == (6, 4)
    assert len({tuple(row) for row in obs}) == 6          # six different layouts
    actions = np.zeros(6, dtype=np.int64)
    assert not env.step(actions)[3].any()
    assert env.step(actions)[3].all()                      # truncated together
    reset_obs, reward, _, truncated, _ = env.step(actions)
    assert np.array_equal(reset_obs, obs) and not reward.any() and not truncated.any()


def test_make_with_render_mode_ansi_renders_the_state_as_text():
    # gymnasium.make(..., render_mode=...) raised TypeError: __init__ took no render_mode
    env = gymnasium.make(ENV_ID, scenario=str(SCENARIOS / "nyc_mmwave.toml"), render_mode="ansi")
    assert env.metadata["render_modes"] == ["ansi", "rgb_array"]
    assert env.metadata["render_fps"] > 0
    env.reset(seed=0)
    _, _, _, _, info = env.step(0)
    text = env.render()
    assert text.startswith("step 1/300  UAV x=-1.0 y=-1.0 h=49.0 m")
    assert f"sum rate {info['sum_rate_bps'] / 1e6:.1f} Mbit/s" in text
    assert gymnasium.make(ENV_ID, scenario=str(SCENARIOS / "nyc_mmwave.toml")).render_mode is None


def test_an_unsupported_render_mode_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"^render_mode 'human' is not supported; "
                                         r"allowed: None, 'ansi', 'rgb_array'$"):
        NomaUavEnv(make_scenario(), render_mode="human")
    with pytest.raises(ValueError, match=r"allowed: None, 'ansi'$"):  # a picture: one env's
        NomaUavVectorEnv(make_scenario(), num_envs=2, render_mode="rgb_array")


def test_make_without_a_scenario_uses_the_shipped_default():
    # gymnasium.make(ENV_ID) failed: the scenario argument was required
    env = gymnasium.make(ENV_ID)
    shipped = load_scenario(SCENARIOS / "nyc_mmwave.toml")
    assert env.unwrapped.scenario == shipped
    assert env.reset(seed=0)[0].shape == (17,)
    vec = gymnasium.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    assert vec.scenario == shipped


def test_the_default_scenario_is_found_inside_an_installed_wheel(tmp_path, monkeypatch):
    # a wheel has no source checkout around it: its scenarios are in adaptsky/shipped/
    package = tmp_path / "site-packages" / "adaptsky"
    (package / "shipped" / "scenarios").mkdir(parents=True)
    inside = package / "shipped" / "scenarios" / "nyc_mmwave.toml"
    inside.write_text((SCENARIOS / "nyc_mmwave.toml").read_text())
    monkeypatch.setattr(shipped_files, "PACKAGE_ROOT", package)
    assert shipped_files.default_scenario_path() == inside
    inside.unlink()
    with pytest.raises(ScenarioError, match=r"nyc_mmwave.toml: the default scenario is missing "
                                            r"from this installation; reinstall adaptsky"):
        shipped_files.default_scenario_path()


MOVING_SAMPLED = {"radio": SUB6_RADIO, "train": {"steps": 3},
                  "channel": {"model": "sub6-al-hourani", "los": "sampled"}}


def _sync_envs(scenario, num_envs, per_layout):
    """Gymnasium's SyncVectorEnv over single envs (sub-env i on layout i if ``per_layout``)."""
    if not per_layout:
        return gymnasium.make_vec(ENV_ID, num_envs=num_envs, vectorization_mode="sync",
                                  scenario=scenario)
    return gymnasium.vector.SyncVectorEnv([
        lambda i=i: gymnasium.make(ENV_ID, scenario=scenario, layout_index=i)
        for i in range(num_envs)])


@pytest.mark.parametrize("placement", ["listed", "uniform"])
def test_vector_env_with_a_list_of_seeds_equals_the_sync_vector_env(placement):
    # the native vector env used only the first seed of a list: every sub-env drew from it
    users = {"speed_m_per_step": 1.0, "positions_m": [list(xy) for xy in TRAINING_LAYOUT_M]}
    if placement == "uniform":
        users |= {"positions_m": None, "count": 4}
    scenario = make_scenario(users=users, **MOVING_SAMPLED)
    native = gymnasium.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point",
                                scenario=scenario)
    sync = _sync_envs(scenario, 3, per_layout=placement == "uniform")
    native_obs, native_info = native.reset(seed=[1, 2, 3])
    sync_obs, sync_info = sync.reset(seed=[1, 2, 3])
    assert np.array_equal(native_obs, sync_obs)
    assert sorted(native_info) == sorted(sync_info)
    layouts = {row.tobytes() for row in native.batch.layouts_m}
    assert len(layouts) == (3 if placement == "uniform" else 1)
    rng = np.random.default_rng(0)
    for _ in range(7):      # two episodes of 3 steps and their next-step autoresets
        actions = rng.integers(0, 32, size=3)
        for got, want in zip(native.step(actions), sync.step(actions), strict=True):
            if isinstance(want, dict):
                assert sorted(got) == sorted(want)
                for key in want:
                    assert np.array_equal(got[key], want[key]), key
            else:
                assert np.array_equal(got, want)


def test_vector_env_seeds_are_per_environment():
    scenario = make_scenario(**MOVING_SAMPLED)
    env = NomaUavVectorEnv(scenario, num_envs=2)
    env.reset(seed=[5, 5])
    same = env.step(np.array([0, 0]))[4]["los"]
    env.reset(seed=[5, 6])
    assert np.array_equal(same[0], same[1])
    with pytest.raises(ValueError, match="seed must list 2 seeds"):
        env.reset(seed=[1, 2, 3])


def test_vector_env_info_has_a_mask_for_every_key():
    # Gymnasium's vector envs give info["x"] and info["_x"] (which sub-envs have x)
    env = NomaUavVectorEnv(make_scenario(train={"steps": 1}), num_envs=3)
    for info in (env.reset(seed=0)[1], env.step(np.zeros(3, dtype=np.int64))[4]):
        for key in ("uav_m", "alpha", "gain", "los", "p_los", "rate_bps", "sum_rate_bps",
                    "fairness"):
            assert info[f"_{key}"].dtype == bool and info[f"_{key}"].tolist() == [True] * 3
            assert len(info[key]) == 3


def test_single_env_layout_index_picks_the_vector_envs_layout():
    scenario = make_scenario(users={"positions_m": None, "count": 4})
    vector = NomaUavVectorEnv(scenario, num_envs=3)
    for index in range(3):
        single = NomaUavEnv(scenario, layout_index=index)
        assert np.array_equal(single.batch.layouts_m[0], vector.batch.layouts_m[index])
    with pytest.raises(ValueError, match="users_m or layout_index, not both"):
        NomaUavEnv(scenario, users_m=vector.batch.layouts_m[0], layout_index=1)


def test_vector_env_renders_every_environment():
    env = NomaUavVectorEnv(make_scenario(), num_envs=2, render_mode="ansi")
    env.reset(seed=0)
    frames = env.render()
    assert len(frames) == 2 and all(frame.startswith("step 0/300  UAV x=0.0") for frame in frames)
