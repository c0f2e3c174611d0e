"""Greedy evaluation during training, and the best policy so far (docs/training.md).

Every ``train.eval_every`` episodes each member of a stack runs its greedy policy (no
exploration, no learning) for ``train.eval_steps`` steps from the episode start, on the
evaluation layouts: the training layout (unless ``users.placement = "fresh"``, where there is
none) and ``train.eval_layouts`` held-out uniform layouts drawn from ``train.eval_layout_seed``
and paired near-far. Its steady state is the mean over the last 100 steps (as ``adaptsky
eval`` measures it), compared with the oracle of each layout where the scenario allows one
(``channel.los`` not ``"sampled"``); for several UAVs the reference is best response
(docs/model.md §9), stored in the oracle's place and named in progress as what it is. The
reference is computed before the first episode, with progress (round, UAV, time left).

The evaluation has environments and generators of its own: it changes nothing of training,
which gives the same numbers with or without it. Every evaluation draws the same numbers
(common random numbers, :func:`evaluation_seeds`): the environment of the l-th layout of a
group, for every member, is re-seeded with (0, l) before each rollout, so the LoS draws,
fading and user moves are those of every other evaluation, of every other seed, of the same
seed in another stack, and of a resumed run; (0, 0) is seed 0, the generator of ``adaptsky
eval`` on one layout. Two evaluations then differ only by their policies, and no generator of
an evaluation needs a checkpoint.

Where the users move (docs/model.md §3) there is no oracle of a layout; each evaluation then
also flies the tracking baseline (docs/evaluation.md) through the same draws (on the same
environments, re-seeded alike: the same user moves, LoS draws and fading), and stores its steady
sum rate beside the policy's (the same at every evaluation). The per-step oracle, 100
searches a layout per evaluation, is left to ``adaptsky eval`` and ``baseline``.

The score that chooses the best policy: percent of the oracle on the training layout, or, for
``fresh`` placement, the mean percent of the oracle over the held-out layouts; without an
oracle, the same sum rates in bit/s.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.envs.observations import AgentView
from adaptsky.errors import AdaptskyError
from adaptsky.progress import Reporter, Silent, Tick, WorkProgress
from adaptsky.references.reference import Reference
from adaptsky.references.registry import layout_reference, reference_words
from adaptsky.rollouts.metrics import STEADY_STEPS, percent_of
from adaptsky.rollouts.several_uavs import OnSearch
from adaptsky.rollouts.tracking import tracking_target
from adaptsky.scenario import Scenario
from adaptsky.scenario.variants import eval_scenario
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.noma import jain_fairness
from adaptsky.sim.state import users_move
from adaptsky.store.layout import FORMAT_VERSION, evaluation_fields
from adaptsky.store.search_cache import cache_folder, physics_json
from adaptsky.units import plural

FloatArray = NDArray[np.float64]
# the [train] keys of the evaluation: they change nothing of training
EVALUATION_KEYS = ("eval_every", "eval_steps", "eval_layouts", "eval_layout_seed")
# the columns of /seeds/<S>/evaluations (docs/file-format.md); NaN where a column does not apply
COLUMNS = tuple(field.name for field in evaluation_fields(FORMAT_VERSION))
# the entropy of every evaluation's draws: seed 0, as ``adaptsky eval``
EVALUATION_SEED = 0


@dataclass(frozen=True)
class LayoutGroup:
    """Layouts evaluated under one pairing: the scenario they run in, their positions
    (L, N, 2) and each one's oracle sum rate (L,), NaN where there is none."""

    scenario: Scenario
    layouts_m: FloatArray
    oracle_bps: FloatArray


@dataclass(frozen=True)
class EvaluationSet:
    """What a run evaluates on: the training layout (or None) and the held-out layouts (or
    None). Computed once when the run file is made, and stored in it."""

    training: LayoutGroup | None
    held_out: LayoutGroup | None

    @property
    def groups(self) -> list[LayoutGroup]:
        return [group for group in (self.training, self.held_out) if group is not None]

    def arrays(self) -> dict[str, FloatArray]:
        """The layouts and oracle of each group, as a run file's ``/evaluation`` holds them."""
        return {f"{name}_{key}": value for name, group in
                (("training", self.training), ("heldout", self.held_out)) if group is not None
                for key, value in (("layouts_m", group.layouts_m),
                                   ("oracle_bps", group.oracle_bps))}


def evaluation_set(scenario: Scenario, oracle_bps: list[FloatArray] | None = None,
                   progress: Reporter | None = None) -> EvaluationSet | None:
    """The scenario's evaluation layouts (None when it evaluates nothing, also when its run
    is shorter than ``eval_every``), with their oracle: ``oracle_bps`` as stored (one array
    per group, training layout first), else computed (about 2 s per layout for the paper's
    lattice, minutes for best response), saying so first to ``progress`` and showing the
    search there. The held-out layouts are those of ``eval --layouts`` (uniform, near-far)."""
    train = scenario.train
    if train.eval_every == 0 or train.episodes < train.eval_every:
        return None  # nothing to evaluate (a longer --resume computes it then)
    groups: dict[str, tuple[Scenario, int]] = {}
    if scenario.users.placement != "fresh":
        groups["training"] = (scenario, 1)
    if train.eval_layouts:
        groups["held-out"] = (eval_scenario(scenario, train.eval_layouts,
                                            train.eval_layout_seed), train.eval_layouts)
    if not groups:
        return None
    stored = dict(zip(groups, oracle_bps or [], strict=False))
    layouts = {name: user_layouts(variant, count) for name, (variant, count) in groups.items()}
    wanted = [name for name, (variant, _) in groups.items()
              if name not in stored and layout_reference(variant) is not None]
    cached = {name: found for name in wanted
              if (found := cached_reference_bps(groups[name][0], layouts[name])) is not None}
    if cached:
        (progress or Silent()).note(
            f"{_reference_phrase(scenario)} on "
            f"{_where({name: groups[name][1] for name in cached})} from the cache "
            f"({cache_folder()}; docs/training.md)")
    stored |= cached
    searched = [name for name in wanted if name not in cached]
    found: dict[str, LayoutGroup] = {}
    with _reference_stage(scenario, {name: groups[name][1] for name in searched},
                          progress) as ticks:
        for name, (variant, count) in groups.items():
            layouts_m = layouts[name]
            if name in stored:
                ceiling = stored[name]
            elif name in ticks:
                ceiling = reference_bps(variant, layouts_m, ticks[name])
            else:
                ceiling = np.full(count, np.nan)
            found[name] = LayoutGroup(variant, layouts_m, np.asarray(ceiling, dtype=np.float64))
    return EvaluationSet(found.get("training"), found.get("held-out"))


def reference_name(scenario: Scenario) -> str:
    """What the greedy evaluations are a percentage of: 'oracle' for one UAV, 'best
    response' for several (docs/model.md §9)."""
    return reference_words(scenario)


@contextmanager
def _reference_stage(scenario: Scenario, counts: dict[str, int], progress: Reporter | None
                     ) -> Iterator[dict[str, OnSearch]]:
    """A stage of ``progress`` for the reference searches of the groups ``counts`` (their
    layouts), announced in a line ('computing best response on the training layout and 8
    held-out layouts for the greedy evaluations (3 UAVs) ...'): a tick per group, counting
    on from the groups before it."""
    if not counts:
        yield {}
        return
    reporter = progress or Silent()
    uavs = f" ({scenario.uav.count} UAVs)" if scenario.uav.count > 1 else ""
    reporter.note(f"computing {_reference_phrase(scenario)} on {_where(counts)} for the "
                  f"greedy evaluations{uavs} ...")
    with WorkProgress(reporter) as work, \
            work.stage(reference_name(scenario), sum(counts.values()), "layout") as tick:
        ticks: dict[str, OnSearch] = {}
        before = 0
        for group, count in counts.items():
            ticks[group] = functools.partial(_shifted, tick, before)
            before += count
        yield ticks


def _reference_phrase(scenario: Scenario) -> str:
    """'the oracle' or 'best response'."""
    name = reference_name(scenario)
    return f"the {name}" if name == "oracle" else name


def _where(counts: dict[str, int]) -> str:
    """'the training layout and 8 held-out layouts' of the groups ``counts``."""
    return " and ".join("the training layout" if name == "training"
                        else plural(count, "held-out layout") for name, count in counts.items())


def _shifted(tick: Tick, before: int, done: float, detail: str = "") -> None:
    """``tick`` of a stage of several groups: ``done`` of a group after ``before`` layouts."""
    tick(before + done, detail)


_REFERENCES: dict[tuple[str, bytes], FloatArray] = {}


def cached_reference_bps(scenario: Scenario, layouts_m: FloatArray) -> FloatArray | None:
    """The reference of every layout if this process or the search cache
    (:mod:`adaptsky.store.search_cache`) has it, else None."""
    memo_key = (physics_json(scenario), layouts_m.tobytes())
    if memo_key not in _REFERENCES:
        found = _layout_reference(scenario).layout_bps(scenario, layouts_m, cached_only=True)
        if found is None:
            return None
        _REFERENCES[memo_key] = found
    return _REFERENCES[memo_key].copy()


def reference_bps(scenario: Scenario, layouts_m: FloatArray,
                  on_progress: OnSearch | None = None) -> FloatArray:
    """The reference sum rate (L,) of every layout (:func:`~adaptsky.references.registry.
    layout_reference`): the oracle; for several UAVs best response (docs/model.md §9). Kept
    per process and in the search cache for the scenario's physics and layouts, so the runs
    of a stack, and other processes on the machine, which share them, search once (best
    response takes minutes a layout). ``on_progress`` hears the layouts done (a fraction
    within one) and where the search is."""
    memo_key = (physics_json(scenario), layouts_m.tobytes())
    if memo_key not in _REFERENCES:
        _REFERENCES[memo_key] = _layout_reference(scenario).layout_bps(
            scenario, layouts_m, on_progress)
    return _REFERENCES[memo_key].copy()


def _layout_reference(scenario: Scenario) -> Reference:
    """The registry's reference of the greedy evaluations on ``scenario``; refused in one
    line where there is none."""
    found = layout_reference(scenario)
    if found is None:
        raise AdaptskyError(f"scenario '{scenario.name}': no reference has a value per layout "
                            "(gains drawn at random, or users that move)")
    return found


def evaluation_seeds(layouts: int) -> list[np.random.SeedSequence]:
    """The seeds of one member's environments on a group of ``layouts`` layouts, the same at
    every evaluation: (0, l) for layout l (module docstring)."""
    return [np.random.SeedSequence([EVALUATION_SEED, index]) for index in range(layouts)]


def _nan_reduce(reduce: object, values: FloatArray) -> float:
    """np.nanmean or np.nanmedian of ``values``; NaN, quietly, when every value is NaN."""
    if np.isnan(values).all():
        return float("nan")
    return float(reduce(values))  # type: ignore[operator]


class GreedyEvaluator:
    """Greedy rollouts of a stack on the members' :class:`EvaluationSet` s, which share their
    layouts (a stack's members share everything but ``reward`` and ``train``) and may differ
    in their oracles (``reward.min_se``); ``greedy`` maps observations (S, n, obs) to
    actions (S, n). Where the users move, each environment also flies the tracking
    baseline, re-seeded alike: the same draws (module docstring)."""

    def __init__(self, evaluations: list[EvaluationSet], steps: int) -> None:
        self.evaluations, self.members, self.steps = evaluations, len(evaluations), steps
        groups = evaluations[0].groups
        # every environment's seed, member-major: each member's layouts alike
        self.seeds = [evaluation_seeds(len(group.layouts_m)) * self.members for group in groups]
        self.envs = [self._env(group, seeds) for group, seeds in zip(groups, self.seeds,
                                                                     strict=True)]
        # which groups also fly the tracking baseline: where the users move
        self.tracks = [users_move(group.scenario) for group in groups]

    def _env(self, group: LayoutGroup, seeds: list[np.random.SeedSequence]) -> NetworkBatch:
        return NetworkBatch(group.scenario, num_envs=self.members * len(group.layouts_m),
                            seed=seeds, users_m=np.concatenate([group.layouts_m] * self.members),
                            view=AgentView.of(group.scenario))

    def run(self, greedy: object) -> list[dict[str, float]]:
        """One evaluation: per member its row of :data:`COLUMNS` (without ``episode``)."""
        results: list[dict[str, float]] = [{} for _ in range(self.members)]
        for index, (env, seeds, tracks) in enumerate(zip(self.envs, self.seeds, self.tracks,
                                                         strict=True)):
            rates = self._rollout(env, seeds, greedy)  # (steady steps, S, L, N)
            steady = _per_member(rates, _steady_sum_bps)  # (S, L)
            fairness = _per_member(rates, lambda each: jain_fairness(each).mean(axis=0))
            tracking = (_per_member(self._tracking(env, seeds), _steady_sum_bps) if tracks
                        else np.full_like(steady, np.nan))
            for member, (row, evaluation) in enumerate(zip(results, self.evaluations,
                                                           strict=True)):
                group = evaluation.groups[index]
                pct = percent_of(steady[member], group.oracle_bps)
                if group is evaluation.training:
                    row.update(sum_rate_bps=float(steady[member, 0]),
                               fairness=float(fairness[member, 0]), pct_oracle=float(pct[0]),
                               tracking_bps=float(tracking[member, 0]))
                else:
                    row.update(heldout_sum_rate_bps=float(steady[member].mean()),
                               heldout_fairness=float(fairness[member].mean()),
                               heldout_pct_oracle=_nan_reduce(np.nanmean, pct),
                               heldout_pct_oracle_median=_nan_reduce(np.nanmedian, pct),
                               heldout_tracking_bps=float(tracking[member].mean()))
        for row, evaluation in zip(results, self.evaluations, strict=True):
            for column in COLUMNS:
                if column not in ("episode", "score"):
                    row.setdefault(column, float("nan"))
            row["score"] = score(row, evaluation)
        return results

    def _rollout(self, env: NetworkBatch, seeds: list[np.random.SeedSequence],
                 greedy: object) -> FloatArray:
        """Rates (K, S, L, N) of the last K = min(100, steps) steps of a greedy rollout."""
        def step(obs: np.ndarray) -> tuple[object, ...]:
            actions = np.asarray(greedy(  # type: ignore[operator]
                obs.reshape(self.members, env.num_envs // self.members, -1)))
            # (S, L) indices, or (S, L, D) continuous controls, to one row per environment
            return env.step(actions.reshape(env.num_envs, *actions.shape[2:]))
        return self._steady(env, seeds, step)

    def _tracking(self, env: NetworkBatch, seeds: list[np.random.SeedSequence]
                  ) -> FloatArray:
        """Rates (K, S, L, N) of the tracking baseline's last K steps on ``env``, re-seeded
        from ``seeds`` as the policy's rollout was: the same draws."""
        return self._steady(env, seeds, lambda _: (None, None, None,
                                                   env.fly_step(*tracking_target(env))))

    def _steady(self, env: NetworkBatch, seeds: list[np.random.SeedSequence], step: object
                ) -> FloatArray:
        """Rates (K, S, L, N) of the last K = min(100, steps) of ``steps`` calls of ``step``
        (observation -> (observation, reward, done, state)) from a reset of ``env`` with
        fresh generators from ``seeds``."""
        members = self.members
        layouts = env.num_envs // members
        obs, _ = env.reset(seed=seeds)
        kept = min(STEADY_STEPS, self.steps)
        rates = np.empty((kept, members, layouts, env.num_users))
        with np.errstate(all="ignore"):
            for index in range(self.steps):
                obs, _, _, state = step(obs)  # type: ignore[operator]
                if index >= self.steps - kept:
                    rates[index - self.steps + kept] = state.rate_bps.reshape(
                        members, layouts, -1)
        return rates


def _steady_sum_bps(rates: FloatArray) -> FloatArray:
    """The mean sum rate (L,) of one member's rates (K, L, N)."""
    return rates.sum(axis=-1).mean(axis=0)


def _per_member(rates: FloatArray, reduce: Callable[[FloatArray], FloatArray]) -> FloatArray:
    """``reduce`` of each member's rates (K, L, N) of ``rates`` (K, S, L, N), stacked (S,
    L): member by member, as alone, so that a member's numbers do not depend on its stack
    (numpy sums the axis K of (K, S, L) in another order than that of (K, L))."""
    return np.stack([reduce(rates[:, member]) for member in range(rates.shape[1])])


def score(row: dict[str, float], evaluation: EvaluationSet) -> float:
    """What chooses the best policy (module docstring); higher is better."""
    if evaluation.training is not None:
        oracle = layout_reference(evaluation.training.scenario) is not None
        return row["pct_oracle"] if oracle else row["sum_rate_bps"]
    oracle = (evaluation.held_out is not None
              and layout_reference(evaluation.held_out.scenario) is not None)
    return row["heldout_pct_oracle"] if oracle else row["heldout_sum_rate_bps"]
