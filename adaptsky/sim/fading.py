"""Small-scale fading, built in for every channel model (docs/model.md §11): the maths as
pure functions, and :class:`FadingStage`, the state of the channel stage's fading (the
scattered part s of every link, kept from step to step).

A link's power gain is its large-scale gain times ``|h|^2`` (mean 1), with

    h = sqrt(K / (K + 1)) + sqrt(1 / (K + 1)) s,   s ~ CN(0, 1)         (eq. 11.1)

and K = 0 (Rayleigh, ``|h|^2 = |s|^2 ~ Exp(1)``) for model ``rayleigh`` and for NLoS links;
for LoS links of model ``rician`` the K-factor of the elevation angle theta

    K(theta) = K0 exp((2 / pi) ln(K90 / K0) theta)                      (eq. 11.2)

(linear in theta in dB). The scattered part is correlated from step to step,

    s_t = rho s_{t-1} + sqrt(1 - rho^2) w_t,   w_t ~ CN(0, 1)           (eq. 11.3)

with s drawn fresh at every reset. Each w is two standard normals (its real and imaginary
parts times sqrt(1/2)); environment b's come from its generator (or all from one shared
generator), drawn in blocks of several steps' worth (docs/model.md §11, the draws): a step's
fading then costs numpy work on arrays, not a call per environment.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Fading

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
ComplexArray = NDArray[np.complex128]
Generators = np.random.Generator | list[np.random.Generator]

BLOCK_NORMALS = 4096
"""Normals an environment draws from its generator at once, at most (a block of steps)."""
MAX_BLOCK_STEPS = 64
"""Steps of fading drawn at once, at most (docs/model.md §11, the draws)."""
_DB_TO_LOG_ROOT = math.log(10) / 20      # ln sqrt(10^(x / 10)) per dB x
_HALF_ROOT = math.sqrt(0.5)              # the scale of each part of CN(0, 1)


# ---- the maths -------------------------------------------------------------------------------

def k_factor(elevation_rad: FloatArray | float, k0_db: float, k90_db: float
             ) -> FloatArray | float:
    """K(theta), linear, of eq. 11.2: ``K0 exp((2/pi) ln(K90/K0) theta)`` with K0, K90 the
    linear values of ``k0_db``, ``k90_db``; ``K(0) = K0``, ``K(pi/2) = K90``."""
    k0, k90 = 10 ** (k0_db / 10), 10 ** (k90_db / 10)
    return k0 * np.exp((2 / np.pi) * math.log(k90 / k0) * np.asarray(elevation_rad))


def root_k_factor(elevation_deg: FloatArray, k0_db: float, k90_db: float) -> FloatArray:
    """sqrt(K(theta)) of eq. 11.2 for elevations in degrees (B', N): in dB K is
    ``k0_db + (k90_db - k0_db) theta / 90 deg``, so its root is one ``exp`` of a linear
    function (three array operations)."""
    root = np.multiply(elevation_deg, _DB_TO_LOG_ROOT * (k90_db - k0_db) / 90.0)
    root += _DB_TO_LOG_ROOT * k0_db
    return np.exp(root, out=root)


def power_gain(real: FloatArray, imag: FloatArray, root_k: FloatArray | None) -> FloatArray:
    """``|h|^2`` of eq. 11.1 from the scattered part s = ``real`` + j ``imag`` and sqrt(K)
    (None or 0: Rayleigh, ``|s|^2``): ``((sqrt K + Re s)^2 + (Im s)^2) / (K + 1)``."""
    if root_k is None:
        gain = np.square(real)
        gain += np.square(imag)
        return gain
    gain = np.add(root_k, real)
    np.square(gain, out=gain)
    gain += np.square(imag)
    scale = np.square(root_k)
    scale += 1.0
    gain /= scale
    return gain


def ar1(previous: FloatArray, innovation: FloatArray, correlation: float,
        out: FloatArray | None = None) -> FloatArray:
    """s_t of eq. 11.3, ``rho s_{t-1} + sqrt(1 - rho^2) w_t``, for each part of s (real
    arrays); written into ``out`` where given (it may be ``previous``)."""
    update = np.multiply(innovation, math.sqrt(1.0 - correlation ** 2))
    scattered = np.multiply(previous, correlation, out=out)
    scattered += update
    return scattered


# ---- the stage's state -----------------------------------------------------------------------

class FadingStage:
    """The fading of B environments of U UAVs and N users (docs/model.md §11): the scattered
    part s of every link, (2, B, U, N) real and imaginary parts, drawn fresh by the first
    evaluation after :meth:`reset` and carried through eq. 11.3 at every later one.

    Draws: each environment's normals come from its own generator (a list of B) or every
    environment's from one shared generator, a block of ``block_steps`` steps at a time (at
    most :data:`MAX_BLOCK_STEPS`, at most :data:`BLOCK_NORMALS` normals per environment, so
    the block depends on U and N, never on B), drawn when a step finds the block used up, after
    that step's LoS draws: environment b's block is
    ``generator_b.standard_normal((steps, 2, U, N))``, step by step the real and imaginary
    parts of w (times sqrt(1/2)). :meth:`reset` throws away what is left of a block: an
    episode's numbers depend only on the generators' states at its reset.
    """

    def __init__(self, fading: Fading, num_envs: int, num_uavs: int, num_users: int) -> None:
        if fading.model == "none":
            raise ValueError("fading.model 'none' has no fading stage")
        self.rician = fading.model == "rician"
        self.k0_db = fading.k0_db if fading.k0_db is not None else 0.0
        self.k90_db = fading.k90_db if fading.k90_db is not None else 0.0
        self.correlation = fading.correlation or 0.0
        self.shape = (num_envs, num_uavs, num_users)
        links = num_uavs * num_users
        self.block_steps = steps = max(1, min(MAX_BLOCK_STEPS, BLOCK_NORMALS // (2 * links)))
        # environment by environment as drawn, and step by step as used
        self._drawn = np.empty((num_envs, steps, 2, num_uavs, num_users))
        self._steps = np.empty((steps, 2, num_envs, num_uavs, num_users))
        self._scattered: FloatArray | None = None
        self.reset()

    def reset(self) -> None:
        """A new episode: the next evaluation draws a new block and a fresh s."""
        self._used = self.block_steps
        self._scattered = None

    def _draw_block(self, rng: Generators) -> None:
        """The next ``block_steps`` steps' w, into ``_steps`` (each part N(0, 1/2))."""
        if isinstance(rng, list):
            for drawn, generator in zip(self._drawn, rng, strict=True):
                generator.standard_normal(out=drawn)
            np.multiply(self._drawn.transpose(1, 2, 0, 3, 4), _HALF_ROOT, out=self._steps)
        else:
            rng.standard_normal(out=self._steps)
            self._steps *= _HALF_ROOT
        self._used = 0

    def _innovation(self, rng: Generators) -> FloatArray:
        """The step's w (2, B, U, N), a view of the block (drawn first where used up)."""
        if self._used == self.block_steps:
            self._draw_block(rng)
        self._used += 1
        return self._steps[self._used - 1]

    def scattered(self, rng: Generators) -> FloatArray:
        """The step's s (2, B, U, N): fresh after a reset, else eq. 11.3."""
        innovation = self._innovation(rng)
        if self.correlation == 0.0:
            return innovation                  # nothing kept: a view of the block will do
        if self._scattered is None:
            self._scattered = innovation.copy()
        else:
            ar1(self._scattered, innovation, self.correlation, out=self._scattered)
        return self._scattered

    def power_gains(self, elevation_deg: FloatArray, los: BoolArray | None, rng: Generators
                    ) -> FloatArray:
        """``|h|^2`` of every link (B*U, N) at the step's elevations (B*U, N), degrees, and
        LoS states (None: every link LoS); NLoS links are Rayleigh."""
        scattered = self.scattered(rng)
        root_k = None
        if self.rician:
            root_k = root_k_factor(elevation_deg, self.k0_db, self.k90_db)
            if los is not None:
                root_k *= los
        flat = (self.shape[0] * self.shape[1], self.shape[2])
        return power_gain(scattered[0].reshape(flat), scattered[1].reshape(flat), root_k)
