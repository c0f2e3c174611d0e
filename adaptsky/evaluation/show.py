"""``adaptsky show`` as a keyword-only library function (docs/pictures.md): the picture, and
the animation, of one episode. A run file's greedy policy is rolled out on its training layout
from the start, as ``eval`` rolls it out (the same layout, steps and LoS draws: the policy's
trajectory of ``eval RUN.h5``); an eval file's policy and one baseline are drawn as the file
stores them, one above the other."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from adaptsky.drawing.episode import EpisodeData
from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import POLICIES, check_rollout_memory, eval_layouts, read_trained
from adaptsky.progress import Reporter, Silent, WorkProgress
from adaptsky.report.episode_files import (
    DPI,
    FPS,
    animation_format,
    figure_format,
    write_animation,
    write_figure,
)
from adaptsky.report.episodes import eval_episodes, trace_episode
from adaptsky.report.eval_summary import is_eval_file
from adaptsky.rollouts.rollout import greedy_policy, rollout
from adaptsky.scenario import Scenario
from adaptsky.store.atomic import make_parent


@dataclass(frozen=True)
class Shown:
    """What :func:`show` wrote (None: not asked for), its frames, and notes for the user."""

    figure: Path | None
    animation: Path | None
    frames: int = 0
    notes: list[str] = field(default_factory=list)


def run_episode(path: Path, *, seed: int | None = None, policy: str = "best",
                steps: int | None = None, progress: Reporter | None = None
                ) -> tuple[Scenario, EpisodeData, list[str]]:
    """The greedy episode of ``seed``'s ``policy`` (default: the first seed's best; its
    last where it has none, said in a note) on the run's training layout, ``steps`` steps
    (default: ``train.steps``) from the start (users that move walk as in ``eval``: the
    episode has their track); the run's scenario, the episode, the notes."""
    scenario, arrays, chosen, record, _ = read_trained(path, seed, policy)
    steps = steps or scenario.train.steps
    check_rollout_memory(scenario, steps, 1, 1, str(path))
    users_m = eval_layouts(scenario, None)
    with WorkProgress(progress or Silent()) as work, \
            work.stage("policy", steps, "step") as tick:
        trace = rollout(scenario, greedy_policy(scenario, arrays), steps, users_m,
                        on_step=tick)
    notes = []
    if record["policy_asked"] == "best" and record["policy"] == "last":
        notes.append(f"{path}: seed {chosen} has no best policy (no greedy evaluation during "
                     f"training); showing its last policy (episode {record['episode']})")
    # a run on a new layout every episode has no training layout: eval's layout 0 then
    where = "layout 0" if scenario.users.placement == "fresh" else "training layout"
    label = (f"{path.name}, seed {chosen}: {record['policy']} policy (episode "
             f"{record['episode']}), {where}")
    return scenario, trace_episode(scenario, trace, users_m, 0, label), notes


def _refuse(path: Path, kind: str, options: dict[str, object], use: str) -> None:
    given = [name for name, value in options.items() if value is not None]
    if given:
        raise AdaptskyError(f"{given[0]}: {path} is {kind}; {use}")


def show(*, path: Path, out: Path | None = None, animate: Path | None = None,
         seed: int | None = None, policy: str | None = None, layout: int | None = None,
         method: str | None = None, steps: int | None = None, dpi: float = DPI,
         every: int | None = None, fps: float = FPS, progress: Reporter | None = None
         ) -> Shown:
    """The picture of an episode of ``path`` (a run file or an eval file, told apart by their
    HDF5 layout) to ``out`` (.png, .pdf or .svg) and its animation to ``animate`` (.gif or
    .mp4), at least one of them. A run file: ``seed`` and ``policy`` (best or last) choose
    the policy; an eval file: ``layout`` and ``method`` what it holds. Every option is
    checked before any work, and a file is written whole or not at all."""
    if out is None and animate is None:
        raise AdaptskyError("nothing to write: give --out FIG.png (.pdf, .svg), --animate "
                            "FILE.gif (.mp4), or both")
    if out is not None:
        figure_format(out)
    if animate is not None:
        animation_format(animate)
    if policy is not None and policy not in POLICIES:
        raise AdaptskyError(f"--policy: unknown policy '{policy}'; choose best or last")
    for value, option in ((dpi, "--dpi"), (fps, "--fps"), (every, "--every"),
                          (steps, "--steps")):
        if value is not None and not value > 0:
            raise AdaptskyError(f"{option}: {value}; give a number above 0")
    for target in (out, animate):
        if target is not None:
            make_parent(target)
    notes: list[str] = []
    if is_eval_file(path):
        _refuse(path, "an eval file", {"--seed": seed, "--policy": policy},
                "--seed and --policy choose a run file's policy (an eval file holds one)")
        scenario, episodes = eval_episodes(path, layout=layout, method=method, steps=steps)
    else:
        _refuse(path, "a run file", {"--layout": layout, "--method": method},
                "--layout and --method choose what an eval file holds")
        scenario, episode, notes = run_episode(path, seed=seed, policy=policy or "best",
                                               steps=steps, progress=progress)
        episodes = [episode]
    side_m = scenario.area.side_m
    if out is not None:
        write_figure(out, episodes, side_m=side_m, dpi=dpi)
    frames = 0
    if animate is not None:
        frames = write_animation(animate, episodes, side_m=side_m, dpi=dpi, every=every,
                                 fps=fps, progress=progress)
    return Shown(out, animate, frames, notes)
