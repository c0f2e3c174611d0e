"""Branch and bound is a capability a channel model declares (issue 53, item 2;
docs/plugins.md, ``Supports(monotone_gains=True)``), not a list of names: a model that declares
it gets the per-step searches' branch and bound whatever its name, one that does not gets the
exhaustive search, to the same objectives; ``plugins check`` tests the promise."""

from __future__ import annotations

import numpy as np
import pytest
from adaptsky_builtin_channels.mmwave_nyc import MmWaveNyc
from adaptsky_builtin_channels.sub6_al_hourani import Sub6AlHourani
from adaptsky_example_channel.uma_av import UmaAv

from adaptsky.channels import LinkGeometry, Supports, registry
from adaptsky.channels.checker import check_channel_model, structural_problems
from adaptsky.channels.contract import declares_monotone_gains
from adaptsky.channels.registry import PluginInfo
from adaptsky.rollouts.genie import per_step_oracle
from adaptsky.rollouts.search import LatticeBoxes, lattice
from adaptsky.rollouts.step_response import StepResponseSearch, per_step_response
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario

WALK = {"model": "gauss-markov", "mean_speed_mps": 2.0, "heading_sigma_deg": 30.0}


class Declared(MmWaveNyc):
    """The NYC model under a name of its own, declaring the capability (as it inherits)."""

    description = "NYC, declaring monotone gains"


class Undeclared(MmWaveNyc):
    """The same gains, no declaration: the default."""

    description = "NYC, declaring nothing of its gains"
    supports = Supports(carrier_hz=(28e9, 28e9))


class NlosAboveLos(MmWaveNyc):
    """A false promise: NLoS gains above the LoS ones."""

    description = "NYC with NLoS stronger than LoS"

    def gain_nlos(self, geometry: LinkGeometry) -> np.ndarray:
        return 2.0 * self.gain_los(geometry)


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    for name, model in (("nyc-declared", Declared), ("nyc-undeclared", Undeclared)):
        monkeypatch.setitem(registry._loaded, name,
                            PluginInfo(name, "tests", "0", f"tests:{model.__name__}", model))


def _scenario(model: str, uavs: int = 1):
    """A 40 m area, heights 10-30 m, alpha step 0.05, four users walking (eight for two
    UAVs, 10 m apart)."""
    uav = {"start_m": [0.0, 0.0, 20.0], "min_height_m": 10.0, "max_height_m": 30.0,
           "power_step": 0.05}
    if uavs > 1:
        uav.update(count=uavs, min_separation_m=10.0)
    return make_scenario(users={"count": 4 * uavs, "positions_m": None, "mobility": WALK},
                         area={"side_m": 40.0}, uav=uav, channel={"model": model},
                         radio={"reuse": "full"} if uavs > 1 else {})


def test_the_declaration_not_the_name_decides():
    assert declares_monotone_gains(MmWaveNyc) and declares_monotone_gains(Sub6AlHourani)
    assert declares_monotone_gains(Declared())          # inherited, on an instance too
    assert not declares_monotone_gains(Undeclared)
    assert not declares_monotone_gains(UmaAv)            # the example plugin: as before
    assert Supports().monotone_gains is False            # the default: exhaustive search


def test_the_per_step_oracle_bounds_only_a_declaring_model_to_the_same_objectives(registered):
    declared, undeclared = _scenario("nyc-declared"), _scenario("nyc-undeclared")
    users_m = NetworkBatch(declared, 2).users_m
    bounded = per_step_oracle(declared, users_m, 4, seed=1)
    exhaustive = per_step_oracle(undeclared, users_m, 4, seed=1)
    total = LatticeBoxes(lattice(declared)[:3]).count
    assert (exhaustive.points_valued == total).all()     # every point at every step
    assert bounded.points_valued.max() < total           # pruned
    np.testing.assert_array_equal(bounded.users_m, exhaustive.users_m)
    # the same optimum (up to the last bits numpy's vector loops give a point valued at
    # another array position)
    np.testing.assert_allclose(bounded.objective_bps, exhaustive.objective_bps, rtol=1e-12,
                               atol=0)
    assert bounded.objective_bps.min() > 0


def test_best_response_at_every_step_bounds_only_a_declaring_model(registered):
    declared, undeclared = _scenario("nyc-declared", 2), _scenario("nyc-undeclared", 2)
    for scenario, bounded in ((declared, True), (undeclared, False)):
        env = NetworkBatch(scenario, 1, seed=0)
        env.reset()
        assert StepResponseSearch(env, 0, env.users_m[0]).bounded is bounded
    users_m = NetworkBatch(declared, 1, seed=0).users_m
    fast = per_step_response(declared, users_m, 2, seed=0)
    slow = per_step_response(undeclared, users_m, 2, seed=0)
    assert fast.points_valued.sum() < slow.points_valued.sum()
    np.testing.assert_allclose(fast.objective_bps, slow.objective_bps, rtol=1e-12, atol=0)


def test_plugins_check_tests_the_promise():
    assert check_channel_model(Declared) == []
    assert check_channel_model(Sub6AlHourani) == []
    broken = type("Broken", (NlosAboveLos,), {})
    assert check_channel_model(broken) == [
        "monotone_gains: gain_nlos() exceeds gain_los() on some links "
        "(declared Supports(monotone_gains=True))"]
    # the example plugin's NLoS gain rises with the height at 50 m: it may not declare it
    claims = type("Claims", (UmaAv,), {"supports": Supports(monotone_gains=True),
                                       "contract_version": 3})
    assert check_channel_model(claims) == [
        "monotone_gains: gain_nlos() grows with the UAV height at a ground distance of 50 m "
        "(declared Supports(monotone_gains=True))"]
    assert check_channel_model(type("Honest", (NlosAboveLos,), {
        "supports": Supports(carrier_hz=(28e9, 28e9))})) == []   # no promise, no finding
    odd = type("Odd", (MmWaveNyc,), {"supports": Supports(monotone_gains="yes")})
    assert structural_problems(odd) == ["supports: monotone_gains = 'yes' is not True or False"]
