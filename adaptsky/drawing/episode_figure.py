"""The picture of an episode (docs/pictures.md): a top view of the area with the users and the
UAVs' paths, and panels over the steps of every UAV's height, every cluster's power split,
every user's rate and, where given, every UAV's propulsion power. Several episodes (a policy
and a baseline) are blocks one above the other, each over its own steps.

The figure is built once. :meth:`EpisodeFigure.show` says which step to show;
:meth:`EpisodeFigure.rgb` then draws only what changed since the last frame: the new pieces
of the paths and lines onto a kept image of those drawn so far (the trail), then the UAVs'
markers, the cursors and the step over it (blitting on the Agg canvas). A frame of an
animation or of the Gymnasium env's ``render()`` costs the same at step 10 as at step 1000,
and for four UAVs as for one: about 15 ms at 100 dpi (benchmarks/frame_time.py), where a
figure drawn whole costs about 500 ms. :meth:`EpisodeFigure.save` draws the whole picture
as PNG, PDF or SVG. A bare :class:`~matplotlib.figure.Figure` on its own canvas: no pyplot, no
global state, no display.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import matplotlib
import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection, PatchCollection, PathCollection
from matplotlib.colors import Normalize, to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.text import Annotation, Text
from matplotlib.ticker import MaxNLocator

from adaptsky.drawing.episode import EpisodeData, FloatArray
from adaptsky.drawing.formats import FIGURE_FORMATS, figure_bytes
from adaptsky.units import rate_unit

BLOCK_IN = (11.0, 5.0)
"""Width and height of one episode's block, inches: 1100 x 500 pixels at 100 dpi. Its parts
are placed in inches from the block's lower left corner (no layout engine: a draw lays out
nothing), as (left, bottom, width, height):"""
TOP_VIEW_IN = (0.75, 1.0, 3.5, 3.5)
COLOURBARS_IN = ((4.35, 1.3, 0.12, 2.9), (5.0, 1.3, 0.12, 2.9))
PANELS_IN = (6.1, 0.5, 2.8, 4.05)
"""Where the panels go, one above the other (a gap of PANEL_GAP_IN between)."""
PANEL_GAP_IN = 0.12
TITLE_IN = (5.5, 4.95)
DPI = 100
CLUSTER_MARKERS = ("o", "s", "D", "v", "P", "X", "h", "<", ">", "p", "d", "H")
"""The marker of cluster k (its subchannel under full reuse) of every UAV; a UAV is a "^",
its start a "*"."""
PATH_CMAP = "viridis"
BUILDING_CMAP = "Greys"
"""Buildings shaded by height: light low, dark tall."""
BUILDING_CMAP_COLOUR = "0.55"
LOS_CMAP = "RdYlBu"
"""Users coloured by the share of their steps in LoS so far: red never, blue always."""
AREA_MARGIN = 0.05
"""Room around the area (its edge dashed), so that users on the edge show whole."""
TRACK_WIDTH = 0.9
"""The line width of a moving user's track (its cluster's colour)."""
START_ALPHA = 0.45
"""The opacity of a moving user's start, a hollow grey marker of its cluster."""
HEADROOM = 0.25
"""A panel whose lines leave its limits (the env's growing episode) gets this much room more."""
LABEL_PT = 8
TICK_PT = 7


def buildings_collection(buildings_m: FloatArray) -> PatchCollection:
    """The footprints (M, 5) [x_min, x_max, y_min, y_max, height], m, as grey squares, darker
    the taller (docs/pictures.md), under everything else."""
    tallest = max(float(buildings_m[:, 4].max(initial=0.0)), 1.0)
    shades = matplotlib.colormaps[BUILDING_CMAP](0.25 + 0.65 * buildings_m[:, 4] / tallest)
    return PatchCollection([Rectangle((x0, y0), x1 - x0, y1 - y0)
                            for x0, x1, y0, y1, _ in buildings_m],
                           facecolors=shades, edgecolors="0.35", linewidths=0.4, zorder=1)


def _links_by_los(episode: EpisodeData) -> bool:
    """Whether the serving links are drawn LoS (solid) or NLoS (dashed): with buildings."""
    return episode.buildings_m is not None and episode.los is not None


def uav_colour(u: int, num_uavs: int) -> str:
    """UAV u's colour: matplotlib's default cycle (one UAV: its first colour)."""
    return "C0" if num_uavs == 1 else f"C{u % 10}"


def _lighter(colour: str, share: float) -> tuple[float, float, float, float]:
    """``colour`` mixed with white, ``share`` of white."""
    red, green, blue, _ = to_rgba(colour)
    return (red + (1 - red) * share, green + (1 - green) * share, blue + (1 - blue) * share,
            1.0)


def cluster_colours(episode: EpisodeData) -> dict[tuple[int, int], Any]:
    """The colour of every cluster (UAV u, cluster k): its line in the power split panel
    (one UAV: the default cycle; several: UAV u's colour, lighter for its later clusters)."""
    pairs = episode.pairs()
    most = max(k for _, k, _ in pairs) or 1
    num_uavs = episode.num_uavs
    return {(u, k): _lighter(uav_colour(u, num_uavs), 0.55 * k / most) if num_uavs > 1
            else f"C{k % 10}" for u, k, _ in pairs}


def _limits(values: FloatArray, pad: float = 0.05) -> tuple[float, float]:
    """Limits that hold ``values`` with a margin (1 either side of a constant 0)."""
    finite = values[np.isfinite(values)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    margin = (high - low) * pad if high > low else (abs(high) * pad or 1.0)
    return low - margin, high + margin


@dataclass
class _Panel:
    """One panel: a line per column of ``values`` (T, C) / ``scale`` over the steps, all in
    one collection (one draw), points where an episode has one or two steps (``dots``), and
    a cursor at the step shown."""

    axes: Axes
    lines: LineCollection
    dots: PathCollection | None
    cursor: Line2D
    values: FloatArray
    scale: float = 1.0
    fixed: bool = False  # limits that never change (alpha: 0 to 1)

    def fits(self) -> bool:
        low, high = self.axes.get_ylim()
        finite = self.values[np.isfinite(self.values)] / self.scale
        return self.fixed or not finite.size or (finite.min() >= low and finite.max() <= high)

    def refit(self) -> None:
        self.axes.set_ylim(*_limits(self.values / self.scale, pad=HEADROOM))

    def grow(self, time: FloatArray, first: int, last: int) -> None:
        """Give the lines (and points) rows ``first`` to ``last``."""
        values = self.values[first:last + 1] / self.scale           # (n, C)
        lines = np.empty((values.shape[1], len(values), 2))
        lines[:, :, 0], lines[:, :, 1] = time[first:last + 1], values.T
        self.lines.set_segments(lines)
        if self.dots is not None:
            self.dots.set_offsets(lines.reshape(-1, 2))
            self.dots.set_facecolors(np.repeat(self.lines.get_colors(), len(values), axis=0))

    def line(self, column: int) -> tuple[FloatArray, FloatArray]:
        """The x and y of a column's line as it holds them now."""
        points = np.asarray(self.lines.get_segments()[column])
        return points[:, 0], points[:, 1]


@dataclass
class _Block:
    """The artists of one episode: those that grow with the steps (``paths``, every UAV's
    segments in one collection; the panels' lines; ``tracks``, every moving user's segments)
    and those that move (``markers``, every UAV in one scatter; ``serving``; the cursors;
    ``step_text``; the users where LoS colours them or they move, and where they move their
    numbers). A collection is one draw whatever it holds: a frame of four UAVs and sixteen
    users draws about as many artists as one of one UAV."""

    episode: EpisodeData
    top: Axes
    step_text: Text
    last_step: int
    held: bool
    paths: LineCollection
    markers: PathCollection
    users: list[tuple[PathCollection, list[int]]] = field(default_factory=list)
    user_labels: list[Annotation] = field(default_factory=list)
    serving: LineCollection | None = None
    panels: list[_Panel] = field(default_factory=list)
    tracks: LineCollection | None = None
    starts: list[tuple[PathCollection, list[int]]] = field(default_factory=list)

    @property
    def growing(self) -> list[Artist]:
        growing: list[Artist] = [self.paths] if self.tracks is None else [self.paths,
                                                                           self.tracks]
        return [*growing, *(artist for panel in self.panels
                            for artist in (panel.lines, panel.dots) if artist is not None)]

    @property
    def moving(self) -> list[Artist]:
        moving: list[Artist] = [self.markers, self.step_text,
                                *(panel.cursor for panel in self.panels)]
        if self.serving is not None:
            moving.append(self.serving)
        if self.episode.los is not None or self.episode.users_move:
            moving += [collection for collection, _ in self.users]
        if self.episode.users_move:
            moving += self.user_labels
        return moving

    def columns(self) -> list[FloatArray]:
        """What each panel draws: heights (T, U), the shares of
        :meth:`~adaptsky.drawing.episode.EpisodeData.share_lines` (T, C) (a pair's first
        listed user's), rates (T, N), propulsion powers (T, U)."""
        episode = self.episode
        shown = [user for _, _, user, _ in episode.share_lines()]
        columns = [episode.uav_m[:, :, 2], episode.alpha[:, shown], episode.rate_bps]
        return columns if episode.power_w is None else [*columns, episode.power_w]

    def path(self, u: int) -> FloatArray:
        """The points (n, 2) UAV u's path joins as it holds them now."""
        segments = np.asarray(self.paths.get_segments())
        per_uav = len(segments) // self.episode.num_uavs
        mine = segments[u * per_uav:(u + 1) * per_uav]
        return np.concatenate([mine[:, 0], mine[-1:, 1]]) if per_uav else np.empty((0, 2))

    def track(self, i: int) -> FloatArray:
        """The points (n, 2) user i's track joins as it holds them now."""
        if self.tracks is None:
            return np.empty((0, 2))
        segments = np.asarray(self.tracks.get_segments())
        per_user = len(segments) // self.episode.num_users
        mine = segments[i * per_user:(i + 1) * per_user]
        return np.concatenate([mine[:, 0], mine[-1:, 1]]) if per_user else np.empty((0, 2))

    def grow(self, drawn: int, last: int) -> None:
        """Give the growing artists the rows after ``drawn`` up to ``last``, joined to row
        ``drawn`` (-1: none drawn yet; a track then starts where its user started)."""
        episode = self.episode
        time = episode.time
        first = max(drawn, 0)
        xy = np.swapaxes(episode.uav_m[first:last + 1, :, :2], 0, 1)   # (U, n, 2)
        segments = np.stack([xy[:, :-1], xy[:, 1:]], axis=2)           # (U, n - 1, 2, 2)
        self.paths.set_segments(segments.reshape(-1, 2, 2))
        self.paths.set_array(np.tile(time[first + 1:last + 1], episode.num_uavs))
        if self.tracks is not None and episode.user_track_m is not None:
            track = episode.user_track_m[first:last + 1]
            if drawn < 0:  # from where the users started
                track = np.concatenate([episode.users_m[None], track])
            xy = np.swapaxes(track, 0, 1)                                # (N, n, 2)
            segments = np.stack([xy[:, :-1], xy[:, 1:]], axis=2)         # (N, n - 1, 2, 2)
            self.tracks.set_segments(segments.reshape(-1, 2, 2))
            self.tracks.set_color(np.repeat(self.track_colours, segments.shape[1], axis=0))
        for panel in self.panels:
            panel.grow(time, first, last)

    @property
    def track_colours(self) -> FloatArray:
        """Every user's track colour (N, 4): its cluster's (:func:`cluster_colours`)."""
        colours = cluster_colours(self.episode)
        return np.array([to_rgba(colours[key]) for key in
                         zip(self.episode.serving_uav.tolist(), self.episode.cluster.tolist(),
                             strict=True)])


class EpisodeFigure:
    """The picture of ``episodes`` (one block each, top to bottom) in an area of side
    ``side_m`` (m), at ``dpi``; ``steps``: the length of the step axes (default: each
    episode's own; the env gives its time limit, so that the axes stay as the episode grows).
    It shows every row until :meth:`show` says otherwise."""

    def __init__(self, episodes: Sequence[EpisodeData], *, side_m: float, dpi: float = DPI,
                 steps: int | None = None) -> None:
        if not episodes:
            raise ValueError("EpisodeFigure needs at least one episode")
        self.side_m, self.steps = side_m, steps
        width, height = BLOCK_IN
        self.figure = Figure(figsize=(width, height * len(episodes)), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.figure)
        self.blocks = [self._block(len(episodes) - 1 - b, episode)
                       for b, episode in enumerate(episodes)]
        for block in self.blocks:
            for artist in (*block.growing, *block.moving):
                artist.set_animated(True)  # left out of the background: drawn per frame
        self._background: Any = None       # the figure without what grows or moves
        self._trail: Any = None            # the background with what grew up to _trail_rows
        self._trail_rows = [-1] * len(self.blocks)
        self._rows = [block.episode.steps - 1 for block in self.blocks]
        self.show()

    # ---- building ----------------------------------------------------------------------

    def _place(self, row: int, left: float, bottom: float, width: float, height: float
               ) -> list[float]:
        """A rect in figure fractions from inches in block row ``row`` (0: the lowest)."""
        figure_w, figure_h = self.figure.get_size_inches()
        bottom += row * BLOCK_IN[1]
        return [left / figure_w, bottom / figure_h, width / figure_w, height / figure_h]

    def _block(self, row: int, episode: EpisodeData) -> _Block:
        rows = 4 if episode.power_w is not None else 3
        top = self.figure.add_axes(self._place(row, *TOP_VIEW_IN))
        left, bottom, width, height = PANELS_IN
        each = (height - (rows - 1) * PANEL_GAP_IN) / rows
        axes: list[Axes] = []
        for i in range(rows):  # from the top down
            rect = self._place(row, left, bottom + (rows - 1 - i) * (each + PANEL_GAP_IN),
                               width, each)
            axes.append(self.figure.add_axes(rect, sharex=axes[0] if axes else None))
        if episode.label:
            x, y = self._place(row, *TITLE_IN, 0.0, 0.0)[:2]
            self.figure.text(x, y, episode.label, ha="center", va="top", fontsize=10)
        steps = self.steps or episode.steps
        dx = episode.step_s or 1.0
        x0 = episode.first_step * dx
        x_end = x0 + (steps - 1) * dx
        step_text = top.text(0.0, 1.02, "", transform=top.transAxes, va="bottom",
                             fontsize=LABEL_PT)  # above the area: no box to draw per frame
        # a baseline's fixed configuration; an env's episode as it grows is never "held"
        held = self.steps is None and episode.held
        norm = Normalize(x0, x_end if x_end > x0 else x0 + dx)
        paths = LineCollection([], cmap=matplotlib.colormaps[PATH_CMAP], norm=norm,
                               linewidths=1.8, zorder=4)
        colours = [uav_colour(u, episode.num_uavs) for u in range(episode.num_uavs)]
        markers = top.scatter(episode.uav_m[0, :, 0], episode.uav_m[0, :, 1], marker="^",
                              s=100, facecolors=colours, edgecolors="black", zorder=6)
        block = _Block(episode, top, step_text, episode.first_step + steps - 1, held, paths,
                       markers)
        self._top_view(row, block, norm)
        block.panels = self._panels(axes, block)
        for axes_ in axes:
            axes_.set_xlim(*((x0 - 0.5 * dx, x0 + 0.5 * dx) if x_end <= x0 else (x0, x_end)))
            axes_.grid(True, alpha=0.3)
            axes_.tick_params(labelsize=TICK_PT)
            if episode.step_s is None:
                axes_.xaxis.set_major_locator(MaxNLocator(integer=True))
        for axes_ in axes[:-1]:
            axes_.tick_params(labelbottom=False)
        axes[-1].set_xlabel(self._x_label(episode), fontsize=LABEL_PT)
        return block

    @staticmethod
    def _x_label(episode: EpisodeData) -> str:
        return "step" if episode.step_s is None else "time $t$ (s)"

    def _top_view(self, row: int, block: _Block, norm: Normalize) -> None:
        episode, top = block.episode, block.top
        half = self.side_m / 2
        room = half * (1 + AREA_MARGIN)
        top.set(xlim=(-room, room), ylim=(-room, room), aspect="equal")
        top.add_patch(Rectangle((-half, -half), 2 * half, 2 * half, fill=False,
                                edgecolor="0.5", linestyle="--", linewidth=0.8))
        top.set_xlabel("$x$ (m)", fontsize=LABEL_PT)
        top.set_ylabel("$y$ (m)", fontsize=LABEL_PT)
        top.tick_params(labelsize=TICK_PT)
        top.grid(True, alpha=0.3)
        num_uavs = episode.num_uavs
        several = num_uavs > 1
        if episode.buildings_m is not None:
            top.add_collection(buildings_collection(episode.buildings_m))
        for k in sorted(set(episode.cluster.tolist())):
            members = np.flatnonzero(episode.cluster == k).tolist()
            serving = episode.serving_uav[members]
            collection = top.scatter(
                episode.users_m[members, 0], episode.users_m[members, 1],
                marker=CLUSTER_MARKERS[k % len(CLUSTER_MARKERS)], s=55, zorder=3,
                facecolors=[_lighter(uav_colour(u, num_uavs), 0.55) for u in serving]
                if several else "0.6",
                edgecolors=[uav_colour(u, num_uavs) for u in serving] if several else "black",
                linewidths=1.8 if several else 1.0)
            block.users.append((collection, members))
            if episode.users_move:  # where they started: faint, hollow
                start = top.scatter(episode.users_m[members, 0], episode.users_m[members, 1],
                                    marker=CLUSTER_MARKERS[k % len(CLUSTER_MARKERS)], s=30,
                                    facecolors="none", edgecolors="0.35", linewidths=0.8,
                                    alpha=START_ALPHA, zorder=2)
                block.starts.append((start, members))
        if episode.users_move:  # every user's track so far, in its cluster's colour
            block.tracks = LineCollection([], linewidths=TRACK_WIDTH, alpha=0.8, zorder=2)
            top.add_collection(block.tracks)
        for i, (x, y) in enumerate(episode.users_m):
            block.user_labels.append(top.annotate(str(i + 1), (x, y), xytext=(5, 4),
                                                  textcoords="offset points", fontsize=TICK_PT))
        if several or _links_by_los(episode):  # a thin line from every user to its UAV
            block.serving = LineCollection(
                [], colors=[uav_colour(u, num_uavs) for u in episode.serving_uav],
                linewidths=0.8 if several else 1.0, alpha=0.45 if several else 0.7,
                zorder=2)
            top.add_collection(block.serving)
        top.add_collection(block.paths)
        if not block.held:  # every UAV's start
            top.scatter(episode.uav_m[0, :, 0], episode.uav_m[0, :, 1], marker="*", s=130,
                        facecolors="white", linewidths=1.5, zorder=5,
                        edgecolors=[uav_colour(u, num_uavs) for u in range(num_uavs)])
        bars = [] if block.held else [(ScalarMappable(norm, PATH_CMAP),
                                       self._x_label(episode))]
        if episode.los is not None:
            bars.append((ScalarMappable(Normalize(0, 1), LOS_CMAP), "LoS share of the steps"))
        for (mappable, label), rect in zip(bars, COLOURBARS_IN, strict=False):
            bar = self.figure.colorbar(mappable, cax=self.figure.add_axes(self._place(row,
                                                                                  *rect)))
            bar.set_label(label, fontsize=LABEL_PT)
            bar.ax.tick_params(labelsize=TICK_PT)
        top.legend(handles=self._top_legend(episode, block.held), loc="upper center",
                   fontsize=TICK_PT, bbox_to_anchor=(0.5, -0.1), ncol=4, frameon=False)

    @staticmethod
    def _top_legend(episode: EpisodeData, held: bool) -> list[Artist]:
        """Proxies: the start, the UAV (now, or at the end), each cluster's marker, moving
        users' start and track, each UAV's colour."""
        grey = "0.4"
        if held:
            handles: list[Artist] = [Line2D([], [], marker="^", color=grey, linestyle="",
                                            markeredgecolor="black", label="held position")]
        else:
            handles = [Line2D([], [], marker="*", markerfacecolor="white", color=grey,
                              markersize=9, linestyle="", label="start"),
                       Line2D([], [], marker="^", color=grey, markeredgecolor="black",
                              linestyle="", label="UAV")]
        for k in sorted(set(episode.cluster.tolist())):
            handles.append(Line2D([], [], marker=CLUSTER_MARKERS[k % len(CLUSTER_MARKERS)],
                                  color="0.3", markerfacecolor="0.7", linestyle="",
                                  label=f"cluster {k + 1}"))
        if episode.users_move:
            handles += [Line2D([], [], marker="o", color="0.35", markerfacecolor="none",
                               alpha=START_ALPHA, linestyle="", label="user start"),
                        Line2D([], [], color="0.35", linewidth=TRACK_WIDTH,
                               label="user track")]
        if episode.num_uavs > 1:
            handles += [Line2D([], [], color=uav_colour(u, episode.num_uavs), linewidth=3,
                               label=f"UAV {u + 1}") for u in range(episode.num_uavs)]
        if episode.buildings_m is not None:
            tallest = float(episode.buildings_m[:, 4].max(initial=0.0))
            handles.append(Rectangle((0, 0), 1, 1, facecolor=BUILDING_CMAP_COLOUR,
                                     edgecolor="0.3", label=f"building (darker: taller, "
                                     f"up to {tallest:.0f} m)"))
        if _links_by_los(episode):
            handles += [Line2D([], [], color="0.3", linestyle=style, label=label)
                        for style, label in (("-", "LoS link"), ("--", "NLoS link"))]
        return handles

    def _panels(self, axes: list[Axes], block: _Block) -> list[_Panel]:
        episode = block.episode
        num_uavs, users = episode.num_uavs, episode.num_users
        heights, shares, rates, *power = block.columns()
        uav_colours = [uav_colour(u, num_uavs) for u in range(num_uavs)]
        panels = [self._panel(axes[0], heights, "height $h$ (m)", uav_colours,
                              [f"UAV {u + 1}" for u in range(num_uavs)] if num_uavs > 1
                              else None)]
        lines = episode.share_lines()
        colours = cluster_colours(episode)
        few = len(episode.pairs()) <= 4
        alpha = self._panel(  # several UAVs: UAV u's colour, lighter for its later clusters
            axes[1], shares, r"power split $\alpha$" if len(lines) == len(episode.pairs())
            else r"power shares $\alpha$", [colours[u, k] for u, k, _, _ in lines],
            [rf"$\alpha_{{{user + 1}}}$" + (
                f" ({'users ' if few else ''}{', '.join(str(i + 1) for i in members)})"
                if user == members[0] else "") for _, _, user, members in lines])
        alpha.axes.set_ylim(-0.03, 1.03)  # a share of 0 or 1 shows beside the frame
        alpha.fixed = True
        panels.append(alpha)
        scale, unit = rate_unit([float(np.nanmax(rates, initial=0.0))])
        panels.append(self._panel(
            axes[2], rates, f"rate $R_i$ ({unit})",
            [f"C{i % 10}" if users <= 10 else matplotlib.colormaps["tab20"](i % 20)
             for i in range(users)],
            [f"$R_{{{i + 1}}}$" for i in range(users)] if users <= 8 else None, scale=scale))
        if power:
            panels.append(self._panel(axes[3], power[0], "propulsion\npower $P$ (W)",
                                      uav_colours, None))
        return panels

    def _panel(self, axes: Axes, values: FloatArray, ylabel: str, colours: Sequence[Any],
               labels: list[str] | None, scale: float = 1.0) -> _Panel:
        """A line per column of ``values`` (T, C) / ``scale`` in ``colours``, named in a
        legend by ``labels`` (None: no legend)."""
        lines = LineCollection([], colors=colours, linewidths=1.2, zorder=2)
        axes.add_collection(lines)
        dots = None
        if (self.steps or len(values)) <= 2:  # one or two points: dots, or nothing shows
            dots = axes.scatter([], [], s=9, zorder=3)
        axes.set_ylabel(ylabel, fontsize=LABEL_PT)
        if labels:
            axes.legend(handles=[Line2D([], [], color=colour, linewidth=1.2, label=label)
                                 for colour, label in zip(colours, labels, strict=True)],
                        fontsize=6, loc="center left", bbox_to_anchor=(1.01, 0.5),
                        frameon=False, ncol=2 if len(labels) > 4 else 1)
        cursor = axes.axvline(0.0, color="0.3", linewidth=0.8, linestyle=":")
        axes.set_ylim(*_limits(values / scale))
        return _Panel(axes, lines, dots, cursor, values, scale)

    # ---- what the artists show ---------------------------------------------------------

    def update(self, episodes: Sequence[EpisodeData]) -> None:
        """More rows of the same episodes (the env's episode as it grows): the same users,
        UAVs and clusters. A panel whose lines leave its limits is widened, and users that
        moved are moved; either redraws the rest once. Shows every row."""
        if len(episodes) != len(self.blocks):
            raise ValueError(f"EpisodeFigure shows {len(self.blocks)} episodes, got "
                             f"{len(episodes)}")
        for block, episode in zip(self.blocks, episodes, strict=True):
            old = block.episode
            if not self.fits(old, episode):
                raise ValueError("EpisodeFigure.update: other UAVs, users, clusters or "
                                 "panels; make a new figure")
            if not np.array_equal(episode.users_m, old.users_m):
                if episode.users_move:  # a new start: in the background
                    for collection, members in block.starts:
                        collection.set_offsets(episode.users_m[members])
                    self._background = None
                else:
                    self._move_users(block, episode.users_m)
            block.episode = episode
            for panel, values in zip(block.panels, block.columns(), strict=True):
                panel.values = values
                if not panel.fits():
                    panel.refit()
                    self._background = None
        self.show()

    @staticmethod
    def fits(old: EpisodeData, new: EpisodeData) -> bool:
        """Whether a figure of ``old`` can show ``new`` (:meth:`update`)."""
        return ((new.num_uavs, new.num_users) == (old.num_uavs, old.num_users)
                and np.array_equal(new.serving_uav, old.serving_uav)
                and np.array_equal(new.cluster, old.cluster)
                and (new.los is None) == (old.los is None)
                and (new.power_w is None) == (old.power_w is None)
                and (new.buildings_m is None) == (old.buildings_m is None)
                and new.users_move == old.users_move)

    def _move_users(self, block: _Block, users_m: FloatArray) -> None:
        """The users' markers and numbers at ``users_m`` (N, 2). Users that stand are in
        the background (drawn again at the next frame); moving users move with every frame."""
        for collection, members in block.users:
            collection.set_offsets(users_m[members])
        for label, position in zip(block.user_labels, users_m, strict=True):
            label.xy = tuple(position)
        if not block.episode.users_move:
            self._background = None

    def show(self, step: int | None = None) -> None:
        """Show rows 0 to ``step`` of every episode (of a shorter one: all its rows), with a
        cursor at ``step`` in the panels; None: every row, no cursor (the whole episode)."""
        self._rows = [block.episode.steps - 1 if step is None
                      else min(step, block.episode.steps - 1) for block in self.blocks]
        for block, last in zip(self.blocks, self._rows, strict=True):
            self._move(block, last, cursor=step is not None)

    def _move(self, block: _Block, last: int, cursor: bool) -> None:
        """The moving artists at row ``last``."""
        episode = block.episode
        time = episode.time
        block.markers.set_offsets(episode.uav_m[last, :, :2])
        users_m = episode.users_at(last)
        if episode.users_move:
            self._move_users(block, users_m)
        if block.serving is not None:
            uavs = episode.uav_m[last, episode.serving_uav, :2]
            block.serving.set_segments(np.stack([users_m, uavs], axis=1))
            if _links_by_los(episode):
                assert episode.los is not None
                block.serving.set_linestyles(["-" if los else "--"
                                              for los in episode.los[last]])
        if episode.los is not None:
            colours = matplotlib.colormaps[LOS_CMAP](episode.los[:last + 1].mean(axis=0))
            for collection, members in block.users:
                collection.set_facecolors(colours[members])
        for panel in block.panels:
            panel.cursor.set_visible(cursor)
            panel.cursor.set_xdata([time[last], time[last]])
        block.step_text.set_text(self._step_text(block, last, cursor))

    @staticmethod
    def _step_text(block: _Block, last: int, cursor: bool) -> str:
        episode = block.episode
        steps = f"{episode.steps} step{'s' if episode.steps != 1 else ''}"
        if not cursor:
            return f"held for {steps}" if block.held else steps
        step = episode.first_step + last
        when = "" if episode.step_s is None else f", $t$ = {step * episode.step_s:g} s"
        return f"step {step}/{block.last_step}{when}"

    # ---- output ------------------------------------------------------------------------

    @property
    def size_px(self) -> tuple[int, int]:
        """(width, height) of a frame, pixels."""
        width, height = self.canvas.get_width_height()
        return width, height

    def rgba(self) -> memoryview:
        """The picture as shown, RGBA (a view of the canvas: valid until the next draw).

        The first call draws what neither grows nor moves, once (again only where limits or
        users changed); each call restores the trail (the growing artists as drawn up to the
        rows of the last call), draws their new rows onto it and keeps that as the next
        trail, then draws what moves over it."""
        canvas = self.canvas
        if self._background is None:
            canvas.draw()
            self._background = self._trail = canvas.copy_from_bbox(self.figure.bbox)
            self._trail_rows = [-1] * len(self.blocks)
        if any(last < drawn for last, drawn in zip(self._rows, self._trail_rows, strict=True)):
            self._trail, self._trail_rows = self._background, [-1] * len(self.blocks)
        canvas.restore_region(self._trail)
        renderer = canvas.get_renderer()
        grew = False
        for block, last, drawn in zip(self.blocks, self._rows, self._trail_rows, strict=True):
            if last > drawn:  # the new rows, joined to the last drawn
                block.grow(drawn, last)
                for artist in block.growing:
                    artist.draw(renderer)
                grew = True
        if grew:
            self._trail, self._trail_rows = canvas.copy_from_bbox(self.figure.bbox), self._rows
        for block in self.blocks:
            for artist in block.moving:
                if artist.get_visible():
                    artist.draw(renderer)
        return canvas.buffer_rgba()

    def rgb(self) -> np.ndarray:
        """The picture as shown, (H, W, 3) uint8 (a copy)."""
        return np.asarray(self.rgba())[:, :, :3].copy()

    def save(self, fmt: str) -> bytes:
        """The picture as shown, whole, as a PNG, PDF or SVG file's bytes
        (:func:`adaptsky.drawing.formats.figure_bytes`)."""
        if fmt not in FIGURE_FORMATS:
            raise ValueError(f"format {fmt!r}: choose from {', '.join(FIGURE_FORMATS)}")
        for block, last in zip(self.blocks, self._rows, strict=True):
            block.grow(-1, last)
        data = figure_bytes(self.figure, fmt, self.figure.dpi)
        self._background = None  # saving drew on the canvas: the next frame starts again
        return data
