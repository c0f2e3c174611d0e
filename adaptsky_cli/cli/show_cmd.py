"""``adaptsky show``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from adaptsky_cli.cli.console import err
from adaptsky_cli.cli.values import conflict, policy_value


def show(
    file: Annotated[Path, typer.Argument(help="run file or eval file (HDF5)", metavar="FILE.h5",
                                         show_default=False)],
    out_file: Annotated[Path | None, typer.Option(
        "--out", metavar="FIG.png", show_default=False,
        help="the figure to write: .png, .pdf or .svg (its format comes from the suffix)")
    ] = None,
    animate: Annotated[Path | None, typer.Option(
        metavar="FILE.gif", show_default=False,
        help="the episode as an animation: .gif, or .mp4 (needs pip install "
        "'adaptsky[video]')")] = None,
    seed: Annotated[int | None, typer.Option(
        min=0, metavar="SEED", show_default=False,
        help="run file: which seed's policy (default: the first)")] = None,
    policy: Annotated[str | None, typer.Option(
        metavar="best|last", show_default=False, callback=policy_value,
        help="run file: the policy of the best greedy evaluation during training (the "
        "default; the last where a run has none) or of the last checkpoint")] = None,
    layout: Annotated[int | None, typer.Option(
        min=0, metavar="L", show_default=False,
        help="eval file: which layout (default: 0)")] = None,
    method: Annotated[str | None, typer.Option(
        metavar="NAME", show_default=False,
        help="eval file: the method drawn beside the policy (default: the first stored)")
    ] = None,
    steps: Annotated[int | None, typer.Option(
        min=1, metavar="N", show_default=False,
        help="steps to show (default: a run's train.steps; all an eval file holds)")] = None,
    dpi: Annotated[int, typer.Option(min=10, max=600, metavar="DPI",
                                     help="pixels per inch")] = 100,
    every: Annotated[int | None, typer.Option(
        min=1, metavar="K", show_default=False,
        help="animation: a frame every K steps (default: at most about 200 frames)")] = None,
    fps: Annotated[int, typer.Option(min=1, max=100, metavar="FPS",
                                     help="animation: frames per second")] = 20,
    quiet: Annotated[bool, typer.Option("--quiet", help="no progress, only warnings")] = False,
) -> None:
    """Draw where the UAVs fly in one episode.

    A run file: the greedy episode of a seed's policy on the training layout. An eval file:
    its policy and one baseline on one layout. A figure (top view, height, power split,
    rates), an animation, or both."""
    if out_file is None and animate is None:
        raise conflict("nothing to write: give --out FIG.png (.pdf, .svg), --animate "
                       "FILE.gif (.mp4), or both")
    from adaptsky.evaluation.show import show as show_episode
    from adaptsky_cli.cli.progress_display import RichReporter

    shown = show_episode(path=file, out=out_file, animate=animate, seed=seed, policy=policy,
                         layout=layout, method=method, steps=steps, dpi=dpi, every=every,
                         fps=fps, progress=RichReporter(err, quiet=quiet))
    for note in shown.notes:
        err.print(note)
    if shown.figure is not None:
        err.print(f"figure: {shown.figure}")
    if shown.animation is not None:
        err.print(f"animation: {shown.animation} ({shown.frames} frames)")
