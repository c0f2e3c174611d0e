"""The gains a scenario's geometry allows: the bounds of the observation's g_i
(docs/environment.md, "Observation bounds").

Every link of a run joins a UAV at (x, y, h) and a user at (x_i, y_i), both in the square
|x|, |y| <= L/2, so its ground distance is d2D in [0, L sqrt(2)], and h is one of the heights
the UAV can reach: its start height, or a bound h_min or h_max, plus whole steps delta_h (moves
of +-delta_h clipped to the bounds). At a fixed height a model's gains do not grow with d2D
(the contract's ``monotone`` rule), so at each reachable height the strongest link is the UAV
straight above a user (d2D = 0) and the weakest the UAV at a corner with the user at the
opposite one (d2D = L sqrt 2). The LoS gain (``los = "always"``), or the LoS and NLoS gains
(``"sampled"``; ``"expected"`` lies between them, the ``expected`` rule), there give the bounds,
widened by a relative 1e-9 for the rounding of the UAV's height along an episode.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import ChannelModel, LinkGeometry
from adaptsky.scenario.models import Uav

FloatArray = NDArray[np.float64]
MARGIN = 1e-9       # relative widening of the bounds: the UAV's height after many rounded steps
CHUNK = 1 << 16     # heights evaluated at once


def reachable_heights(uav: Uav) -> FloatArray:
    """Every height a UAV can take, sorted: h_0 + k delta_h for h_0 a start height (of every
    UAV), h_min and h_max (where a clipped move leaves it), inside [h_min, h_max]."""
    low, high, step = uav.min_height_m, uav.max_height_m, uav.step_m[2]
    start_heights = sorted({h for _, _, h in uav.start_positions_m or []})   # several UAVs
    lattices = [origin + step * np.arange(-math.ceil((origin - low) / step),
                                          math.ceil((high - origin) / step) + 1)
                for origin in (uav.start_m[2], *start_heights, low, high)]
    heights = np.concatenate([*lattices, [low, high]])
    return np.unique(heights[(heights >= low) & (heights <= high)])


def gain_range(channel: ChannelModel, los: str,
               geometry: Callable[[FloatArray, FloatArray], LinkGeometry],
               heights_m: FloatArray, side_m: float) -> tuple[float, float]:
    """The smallest and largest gain of one antenna pair over every link of the scenario
    (module doc), before fading; ``geometry(uav_m, users_m)`` builds the scenario's links."""
    methods = (channel.gain_los,) if los == "always" else (channel.gain_los, channel.gain_nlos)
    half = side_m / 2
    low, high = math.inf, -math.inf
    for chunk in np.array_split(heights_m, max(1, math.ceil(len(heights_m) / CHUNK))):
        uav_m = np.column_stack([np.full(len(chunk), -half), np.full(len(chunk), -half), chunk])
        users_m = np.broadcast_to([[-half, -half], [half, half]], (len(chunk), 2, 2))
        links = geometry(uav_m, np.array(users_m))
        for method in methods:
            gains = method(links)
            high, low = max(high, float(gains[:, 0].max())), min(low, float(gains[:, 1].min()))
    return low * (1 - MARGIN), high * (1 + MARGIN)
