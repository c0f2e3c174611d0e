"""Imperfect channel knowledge (docs/model.md §16): a Gaussian estimate of every link at every
step, drawn after the step's fading from the run's generators.

h_hat = h + e with e ~ CN(0, nmse E|h|^2): the channel's complex coefficient h (1 where no
fading is modelled, E|h|^2 = 1 under the built-in fading) and the link's large-scale gain L,
so g = L |h|^2 and g_hat = L |h_hat|^2. e is circularly symmetric, so |h + e| is distributed
as ||h| + e|: the estimate is drawn as g_hat = (sqrt(g) + sqrt(nmse L / 2) z_1)^2
+ (sqrt(nmse L / 2) z_2)^2 with z_1, z_2 standard normal, independent across links and steps.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Csi
from adaptsky.sim.fading import Generators

FloatArray = NDArray[np.float64]


class CsiStage:
    """The estimates of ``num_envs`` environments' links (B, U, N) under ``csi``."""

    def __init__(self, csi: Csi) -> None:
        self.nmse = csi.nmse
        self.order_on_estimate = csi.order_on == "estimate"

    def estimate(self, gain: FloatArray, large_scale: FloatArray, rng: Generators
                 ) -> FloatArray:
        """g_hat (B, U, N) of the true gains ``gain`` and large-scale gains ``large_scale``
        (B, U, N), with two standard normals per link: from one shared generator (2, B, U, N),
        or environment b's (2, U, N) from ``rng[b]``."""
        if isinstance(rng, list):
            normals = np.stack([r.standard_normal((2, *gain.shape[1:])) for r in rng], axis=1)
        else:
            assert rng is not None
            normals = rng.standard_normal((2, *gain.shape))
        spread = np.sqrt(self.nmse * large_scale / 2.0)
        real = np.sqrt(gain) + spread * normals[0]
        imaginary = spread * normals[1]
        return real * real + imaginary * imaginary
