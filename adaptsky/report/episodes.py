"""Episodes to draw (:class:`~adaptsky.drawing.episode.EpisodeData`) from a rollout's trace or
from an eval file: the arrays of one layout, with every user's serving UAV and cluster as the
simulation associates them on that layout, and where the users move, where each was at
every step (docs/pictures.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from adaptsky.drawing.episode import EpisodeData
from adaptsky.errors import AdaptskyError
from adaptsky.rollouts.rollout import Trace
from adaptsky.scenario import Scenario
from adaptsky.scenario.loading import parse_scenario, parse_toml
from adaptsky.sim.blockage import Blockage
from adaptsky.sim.city import City
from adaptsky.sim.network import NetworkBatch
from adaptsky.store.eval_file import (
    OUTSIDE,
    EvalContents,
    read_eval_contents,
    read_eval_trajectory,
)

FloatArray = NDArray[np.float64]
POLICY = "policy"  # the label of an eval file's policy (evaluation.api.POLICY)


def layout_roles(scenario: Scenario, users_m: FloatArray
                 ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Every user's serving UAV and cluster (N,) on the layout ``users_m`` (N, 2), as the
    simulation pairs and associates them (from the UAVs' start positions)."""
    serving, cluster = NetworkBatch(scenario, num_envs=1, users_m=users_m[None]).roles()
    return serving[0], cluster[0]


def episode_of(scenario: Scenario, users_m: FloatArray, uav_m: FloatArray, alpha: FloatArray,
               rate_bps: FloatArray, los: NDArray[np.bool_] | None = None, label: str = "",
               power_w: FloatArray | None = None, user_track_m: FloatArray | None = None
               ) -> EpisodeData:
    """One layout's episode: ``users_m`` (N, 2), ``uav_m`` (T, 3) or (T, U, 3), ``alpha`` and
    ``rate_bps`` (T, N); ``los`` (T, N) is kept where the scenario draws LoS states;
    ``power_w`` (T, U), every UAV's propulsion power (W) where a model gives one, adds its
    panel; ``user_track_m`` (T, N, 2), every user's position at every step where the users
    move (None: they stand at ``users_m``, the layout, where moving users start). With
    buildings (docs/model.md §12) the layout's city comes along, and the serving links' LoS
    states of every step, computed from the positions where ``los`` is not given."""
    env = NetworkBatch(scenario, num_envs=1, users_m=users_m[None])
    serving, cluster = (roles[0] for roles in env.roles())
    buildings = None
    if env.city is not None:
        buildings = np.column_stack([env.city.footprints_m, env.city.heights_m[0]])
        if los is None:
            los = serving_los(env, np.asarray(uav_m, dtype=np.float64), users_m,
                              user_track_m, serving)
    return EpisodeData(users_m, uav_m, alpha, rate_bps, serving, cluster,
                       los=los if scenario.channel.los in ("sampled", "geometric") else None,
                       power_w=power_w, label=label, user_track_m=user_track_m,
                       buildings_m=buildings)


def serving_los(env: NetworkBatch, uav_m: FloatArray, users_m: FloatArray,
                user_track_m: FloatArray | None, serving: NDArray[np.intp]
                ) -> NDArray[np.bool_]:
    """The LoS state (T, N) of every user's serving link at every step, by the buildings of
    ``env``'s one layout: UAVs ``uav_m`` (T, 3) or (T, U, 3), users at ``users_m`` (N, 2) or
    along ``user_track_m`` (T, N, 2)."""
    assert env.city is not None
    uav_m = uav_m[:, None] if uav_m.ndim == 2 else uav_m
    steps = len(uav_m)
    track = (np.broadcast_to(users_m, (steps, *users_m.shape)) if user_track_m is None
             else np.asarray(user_track_m, dtype=np.float64))
    city = City(env.city.footprints_m, np.repeat(env.city.heights_m, steps, axis=0))
    los = Blockage(city, env.scenario.users.height_m).los(uav_m, np.ascontiguousarray(track))
    return np.take_along_axis(los, serving[None, None, :], axis=1)[:, 0]


def power_of(scenario: Scenario, energy_j: FloatArray) -> FloatArray:
    """Every UAV's power over each step (T, U), W, from its energy of the step (T,) or
    (T, U), J, and ``uav.step_s`` (docs/model.md §10)."""
    energy = np.asarray(energy_j, dtype=np.float64)
    return (energy[:, None] if energy.ndim == 1 else energy) / scenario.uav.step_s


def trace_episode(scenario: Scenario, trace: Trace, users_m: FloatArray, layout: int = 0,
                  label: str = "") -> EpisodeData:
    """Layout ``layout`` of a rollout's ``trace`` on the layouts ``users_m`` (L, N, 2), with
    the users' track where they move (``trace.users_m``)."""
    return episode_of(scenario, users_m[layout], trace.uav_m[:, layout],
                      trace.alpha[:, layout], trace.rate_bps[:, layout],
                      None if trace.los is None else trace.los[:, layout], label,
                      power_of(scenario, trace.energy_j[:, layout]),
                      None if trace.users_m is None else trace.users_m[:, layout])


def eval_scenario_of(path: Path, contents: EvalContents) -> Scenario:
    """The evaluation scenario an eval file stores (validated as a scenario file is)."""
    source = f"{path}:/scenario"
    return parse_scenario(parse_toml(contents.scenario_toml, source), source)


def policy_title(record: dict[str, object]) -> str:
    """'policy of seed 0: best (episode 40)', from an evaluation's policy record; "policy:
    the outside policy 'sb3-ppo'" for one from outside adaptsky (``evaluate_policy``)."""
    if record.get("policy") == OUTSIDE:
        return f"{POLICY}: the outside policy '{record.get('label', '?')}'"
    return (f"{POLICY} of seed {record.get('seed', '?')}: {record.get('policy', '?')} "
            f"(episode {record.get('episode', '?')})")


def eval_episodes(path: Path, *, layout: int | None = None, method: str | None = None,
                  steps: int | None = None) -> tuple[Scenario, list[EpisodeData]]:
    """The eval file's policy and ``method`` (default: the first other method it holds) on
    layout ``layout`` (default 0), their first ``steps`` rows (default: all), as stored (a
    search's configuration is held: its position does not change; users that move, where the
    file stores their positions, move in either). An eval file without
    another method gives the policy alone. One line names what exists where ``layout`` or
    ``method`` does not."""
    contents = read_eval_contents(path)
    labels = contents.labels
    count = len(contents.layouts_m)
    chosen = 0 if layout is None else layout
    if not 0 <= chosen < count:
        raise AdaptskyError(f"--layout {chosen}: {path} holds {count} layout"
                            f"{'s' if count != 1 else ''}: "
                            f"{'0' if count == 1 else f'0 to {count - 1}'}")
    others = [label for label in labels if label != POLICY]
    if method is not None and method not in others:
        what = "the policy itself" if method == POLICY else "not in it"
        raise AdaptskyError(f"--method {method}: {what}; {path} holds "
                            f"{', '.join(others) if others else 'the policy alone'}")
    shown = [label for label in (POLICY if POLICY in labels else None,
                                 method or (others[0] if others else None)) if label]
    scenario = eval_scenario_of(path, contents)
    users_m = contents.layouts_m[chosen]
    record = contents.results.get("policy") or {}
    episodes = []
    for label in shown:
        arrays = read_eval_trajectory(path, label, chosen, steps)
        title = policy_title(record) if label == POLICY else label
        energy = arrays.get("energy_j")
        episodes.append(episode_of(scenario, users_m, arrays["uav_m"], arrays["alpha"],
                                   arrays["rate_bps"], label=f"{title}, layout {chosen}",
                                   power_w=None if energy is None else power_of(scenario,
                                                                                energy),
                                   user_track_m=arrays.get("users_m")))
    return scenario, episodes
