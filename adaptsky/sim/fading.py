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

with s drawn fresh at every reset. Each w is a pair of uniforms through the Box-Muller
transform (:func:`complex_normals`); environment b's uniforms come from its generator (or all
from one shared generator), drawn in blocks of several steps' worth (docs/model.md §11, the
draws): a step's fading then costs numpy work on arrays, not a call per environment.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Fading

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
Generators = np.random.Generator | list[np.random.Generator]

BLOCK_UNIFORMS = 4096
"""Uniforms an environment draws from its generator at once, at most (a block of steps;
docs/model.md §11, the draws)."""


def block_steps(links: int, episode_steps: int) -> int:
    """Steps of fading drawn at once for ``links`` = U N links per environment: an episode
    of ``episode_steps`` (T) split into the fewest equal blocks of at most
    :data:`BLOCK_UNIFORMS` uniforms (2 per link and step), so that little of the last one is
    thrown away at a reset; never depends on B."""
    most = max(1, BLOCK_UNIFORMS // (2 * links))
    return math.ceil(episode_steps / math.ceil(episode_steps / most))
_DB_TO_LOG_ROOT = math.log(10) / 20      # ln sqrt(10^(x / 10)) per dB x


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
        gain = np.square(real, dtype=np.float64)
        gain += np.square(imag, dtype=np.float64)
        return gain
    gain = np.add(root_k, real, dtype=np.float64)
    np.square(gain, out=gain)
    gain += np.square(imag, dtype=np.float64)
    scale = np.square(root_k)
    scale += 1.0
    gain /= scale
    return gain


def innovation_scale(correlation: float) -> float:
    """sqrt(1 - rho^2), the weight of w_t in eq. 11.3 (so that E|s_t|^2 stays 1)."""
    return math.sqrt(1.0 - correlation ** 2)


def ar1(previous: FloatArray, scaled_innovation: FloatArray, correlation: float,
        out: FloatArray | None = None) -> FloatArray:
    """s_t of eq. 11.3, ``rho s_{t-1} + sqrt(1 - rho^2) w_t``, for each part of s (real
    arrays), given ``sqrt(1 - rho^2) w_t`` (:func:`innovation_scale` times w_t, as the
    stage makes it); written into ``out`` where given (it may be ``previous``)."""
    scattered = np.multiply(previous, correlation, out=out)
    scattered += scaled_innovation
    return scattered


def complex_normals(first: FloatArray, second: FloatArray, scale: float = 1.0,
                    out: FloatArray | None = None,
                    work: NDArray[np.float32] | None = None) -> FloatArray:
    """``scale`` times CN(0, 1) draws (2, ...), real and imaginary parts (single precision
    unless ``out`` is double), from uniforms
    u1 = ``first`` and u2 = ``second`` in [0, 1) (both shaped ...): the Box-Muller transform,
    ``sqrt(-ln(1 - u1))`` times ``cos`` and ``sin`` of ``2 pi u2``, each part N(0, 1/2) and
    ``|s|^2 = -ln(1 - u1) ~ Exp(1)`` exactly. 1 - u1 is taken in double precision, the rest
    in single precision (relative error below 1e-6; numpy's double-precision cosine and sine
    cost twenty times as much). ``out`` and ``work`` (3, ...), float32, are workspace kept
    by the caller (a fresh large array costs its page faults)."""
    if out is None:
        out = np.empty((2, *first.shape), dtype=np.float32)
    if work is None:
        work = np.empty((3, *first.shape), dtype=np.float32)
    radius = np.subtract(1.0, first, out=work[2], casting="same_kind")
    np.log(radius, out=radius)
    np.multiply(radius, -scale * scale, out=radius)
    np.sqrt(radius, out=radius)
    angle = np.multiply(second, 2 * np.pi, out=work[0], casting="same_kind")
    np.sin(angle, out=work[1])
    np.cos(angle, out=angle)
    np.multiply(work[0], radius, out=out[0])
    np.multiply(work[1], radius, out=out[1])
    return out


# ---- the stage's state -----------------------------------------------------------------------

class FadingStage:
    """The fading of B environments of U UAVs and N users (docs/model.md §11): the scattered
    part s of every link, (2, B, U, N) real and imaginary parts, drawn fresh by the first
    evaluation after :meth:`reset` and carried through eq. 11.3 at every later one (the
    block keeps w times sqrt(1 - rho^2), the weight eq. 11.3 gives it).

    Draws: each environment's uniforms come from its own generator (a list of B) or every
    environment's from one shared generator, a block of ``block_steps`` steps at a time
    (:func:`block_steps`: it depends on U, N and the episode's T, never on B), drawn when a
    step finds the block used up, after that step's LoS draws: environment b's block is
    ``generator_b.random((2, steps, U, N))``, u1 then u2 of every link and step
    (:func:`complex_normals`). :meth:`reset` throws away what is left of a block: an
    episode's numbers depend only on the generators' states at its reset.
    """

    def __init__(self, fading: Fading, num_envs: int, num_uavs: int, num_users: int,
                 episode_steps: int = 1) -> None:
        if fading.model == "none":
            raise ValueError("fading.model 'none' has no fading stage")
        self.rician = fading.model == "rician"
        self.k0_db, self.k90_db = fading.k_db
        self.correlation = fading.correlation or 0.0
        self.shape = (num_envs, num_uavs, num_users)
        links = num_uavs * num_users
        self.block_steps = steps = block_steps(links, episode_steps)
        # the uniforms environment by environment, as drawn; w part by part, as made; w step
        # by step, as used (each made once per block, so that the elementwise work runs over
        # long contiguous rows)
        self._drawn = np.empty((num_envs, 2, steps, num_uavs, num_users))
        # (w is single precision: complex_normals' products are; s is double)
        self._made = np.empty((2, num_envs, steps, num_uavs, num_users), dtype=np.float32)
        self._work = np.empty((3, *self._made.shape[1:]), dtype=np.float32)
        # w is kept times sqrt(1 - rho^2), the weight eq. 11.3 gives it
        self._scale = innovation_scale(self.correlation)
        self._steps = np.empty((steps, 2, num_envs, num_uavs, num_users), dtype=np.float32)
        self._scattered: FloatArray | None = None
        self.last: FloatArray | None = None
        """The latest step's s (2, B, U, N), as :meth:`scattered` returned it (a view)."""
        self.reset()

    def reset(self) -> None:
        """A new episode: the next evaluation draws a new block and a fresh s."""
        self._used = self.block_steps
        self._scattered = None

    def _draw_block(self, rng: Generators) -> None:
        """The next ``block_steps`` steps' w, into ``_steps``."""
        if isinstance(rng, list):
            for drawn, generator in zip(self._drawn, rng, strict=True):
                generator.random(out=drawn)
        else:
            rng.random(out=self._drawn)
        complex_normals(self._drawn[:, 0], self._drawn[:, 1], self._scale, out=self._made,
                        work=self._work)
        np.copyto(self._steps, self._made.transpose(2, 0, 1, 3, 4))
        self._used = 0

    def _innovation(self, rng: Generators) -> FloatArray:
        """The step's sqrt(1 - rho^2) w (2, B, U, N), a view of the block (drawn first where
        used up)."""
        if self._used == self.block_steps:
            self._draw_block(rng)
        self._used += 1
        return self._steps[self._used - 1]

    def scattered(self, rng: Generators) -> FloatArray:
        """The step's s (2, B, U, N): fresh after a reset, else eq. 11.3 (single precision,
        a view of the block, where rho = 0; double where s is kept)."""
        innovation = self._innovation(rng)
        if self.correlation == 0.0:
            self.last = innovation             # nothing kept: a view of the block will do
            return innovation
        if self._scattered is None:                         # fresh: s = w
            self._scattered = np.divide(innovation, self._scale, dtype=np.float64)
        else:
            ar1(self._scattered, innovation, self.correlation, out=self._scattered)
        self.last = self._scattered
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
