"""users.reassociate_every_s (docs/model.md §3): the association and the NOMA pairing run
again on the users' positions every so many seconds, as they run on a layout, and the start's
come back at every reset; one line where the period is not a whole number of steps."""

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.scenario import parse_scenario
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario

MOVING = {"count": 8, "positions_m": None, "reassociate_every_s": 10.0,
          "mobility": {"model": "random-waypoint", "speed_min_mps": 3.0, "speed_max_mps": 6.0}}


def _roles(env: NetworkBatch) -> tuple[np.ndarray, ...]:
    a = env.association
    return a.serving_uav.copy(), a.first_user.copy(), a.second_user.copy()


def test_every_period_the_association_is_the_one_of_the_positions_then():
    scenario = make_scenario(users=MOVING, uav={"count": 2, "step_s": 2.0},
                             area={"side_m": 200.0})
    env = NetworkBatch(scenario, 3, seed=4)
    env.reset()
    start = _roles(env)
    changed = False
    for step in range(1, 41):
        before = _roles(env)
        env.step(np.zeros(3, dtype=int))
        if step % 5:                                  # 10 s = 5 steps of 2 s
            assert all(np.array_equal(a, b) for a, b in zip(_roles(env), before, strict=True))
            continue
        fresh = NetworkBatch(scenario, 3, users_m=env.users_m.copy())
        assert all(np.array_equal(a, b) for a, b in zip(_roles(env), _roles(fresh),
                                                        strict=True))
        changed |= not all(np.array_equal(a, b) for a, b in zip(_roles(env), start,
                                                                strict=True))
    assert changed                                    # the users moved far enough to matter
    env.reset()
    assert all(np.array_equal(a, b) for a, b in zip(_roles(env), start, strict=True))


def test_without_a_period_the_association_stays_the_starts():
    users = {key: value for key, value in MOVING.items() if key != "reassociate_every_s"}
    env = NetworkBatch(make_scenario(users=users, uav={"count": 2}, area={"side_m": 200.0}),
                       2, seed=1)
    env.reset()
    start = _roles(env)
    for _ in range(30):
        env.step(np.zeros(2, dtype=int))
    assert all(np.array_equal(a, b) for a, b in zip(_roles(env), start, strict=True))


@pytest.mark.parametrize(("every_s", "message"), [
    (3.0, "users.reassociate_every_s = 3 s is not a whole number of steps of uav.step_s = 2 s"),
    (0.0, "reassociate_every_s")])
def test_a_period_that_is_not_whole_steps_is_one_line(every_s, message):
    with pytest.raises(AdaptskyError, match=message):
        parse_scenario({"name": "t", "users": {"count": 4, "reassociate_every_s": every_s},
                        "uav": {"step_s": 2.0}}, "t.toml")
