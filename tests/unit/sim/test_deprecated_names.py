"""The simulator's former names (``NomaUavBatch``, ``MultiUavBatch``, ``network_batch``) still
work for one release, each with a ``DeprecationWarning`` that names ``NetworkBatch``."""

from __future__ import annotations

import numpy as np
import pytest

import adaptsky
from adaptsky.sim import batch, multi_batch
from adaptsky.sim.network import NetworkBatch


@pytest.mark.parametrize(("module", "name"), [(batch, "NomaUavBatch"),
                                              (multi_batch, "MultiUavBatch"),
                                              (adaptsky, "NomaUavBatch"),
                                              (adaptsky, "MultiUavBatch")])
def test_the_former_classes_are_the_one_simulator_and_warn(module, name):
    with pytest.warns(DeprecationWarning, match="NetworkBatch"):
        alias = getattr(module, name)
    assert alias is NetworkBatch
    with pytest.warns(DeprecationWarning, match="NetworkBatch"):   # every use warns
        getattr(module, name)


def test_network_batch_warns_and_builds_the_one_simulator(mmwave):
    with pytest.warns(DeprecationWarning, match="NetworkBatch"):
        env = adaptsky.network_batch(mmwave, num_envs=2, seed=0)
    assert type(env) is NetworkBatch and adaptsky.NetworkBatch is NetworkBatch
    obs, _ = env.reset()
    assert obs.shape == (2, 4 * mmwave.num_users + 1)
    assert np.isfinite(env.step(np.array([0, 1]))[1]).all()
