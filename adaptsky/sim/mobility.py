"""Users that move by a model with a state of its own (docs/model.md §3): random waypoint and
Gauss-Markov, a stage of the step before the channel. (The random walk, which keeps no state,
is :meth:`adaptsky.sim.state.Dynamics.walked`.)

Every step of dt = ``uav.step_s`` seconds draws, from environment b's generator (or all from
one shared generator) before anything else of the step, a fixed number of numbers per user:

- ``random-waypoint``: four uniforms u (a destination's x and y, a speed, a pause), used by
  the users that arrive this step. A user walks straight to its destination at its speed; on
  arrival (within a step of it) it stands there, draws a pause uniform in [0, pause_max_s],
  a new destination uniform in the area and a new speed uniform in [speed_min_mps,
  speed_max_mps], and stands until the pause is over. The reset draws the first destination
  and speed (three uniforms per user).
- ``gauss-markov`` (Liang and Haas 1999): two standard normals n per user,
  s_t = a s_{t-1} + (1 - a) s_mean + sqrt(1 - a^2) sigma_s n_1 and the same for the heading,
  about the user's mean heading (drawn uniform at the reset, with s_0 = s_mean); the user then
  moves s_t dt along its heading (a negative s, possible where sigma_s is large against
  s_mean, moves it backward). At the area's edge it is reflected: the position mirrored into
  the area, the heading and the mean heading mirrored too (pi - theta at x = +-L/2, -theta at
  y = +-L/2).

A step that would end on a building's footprint does not happen (the user stands where it
was, as for the random walk; docs/model.md §12): a random-waypoint user then takes it as an
arrival (a pause, a new destination), a Gauss-Markov user turns round (heading and mean
heading plus pi).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Mobility

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
Generators = np.random.Generator | list[np.random.Generator]

MODELS = ("random-waypoint", "gauss-markov")
"""The models with a state of their own (this module's)."""


def uniforms(rng: Generators, num_envs: int, shape: tuple[int, ...]) -> FloatArray:
    """Uniforms in [0, 1) (B, *shape): from the shared generator at once, or row b from
    environment b's generator."""
    if isinstance(rng, list):
        return np.stack([generator.random(shape) for generator in rng])
    return rng.random((num_envs, *shape))


def normals(rng: Generators, num_envs: int, shape: tuple[int, ...]) -> FloatArray:
    """Standard normals (B, *shape), drawn as :func:`uniforms` are."""
    if isinstance(rng, list):
        return np.stack([generator.standard_normal(shape) for generator in rng])
    return rng.standard_normal((num_envs, *shape))


def reflected(position_m: FloatArray, half_m: float) -> tuple[FloatArray, BoolArray]:
    """Positions (any shape) mirrored into [-half_m, half_m] at the edge they crossed, and
    where a mirror was needed (a step longer than the area is then clipped)."""
    over, under = position_m > half_m, position_m < -half_m
    mirrored = np.where(over, 2 * half_m - position_m,
                        np.where(under, -2 * half_m - position_m, position_m))
    return np.clip(mirrored, -half_m, half_m), over | under


class MobilityStage:
    """The moving users of B environments, N each (module doc): the model's state, reset
    with the users' start positions, and one step at a time."""

    def __init__(self, mobility: Mobility, num_envs: int, num_users: int, half_side_m: float,
                 step_s: float) -> None:
        if mobility.model not in MODELS:
            raise ValueError(f"mobility model '{mobility.model}' has no stage of its own")
        self.mobility = mobility
        self.shape = (num_envs, num_users)
        self.half_m = half_side_m
        self.step_s = step_s
        self._draws: FloatArray | None = None

    # ---- the state at a reset ----------------------------------------------------------------

    def reset(self, rng: Generators) -> None:
        """A new episode: the first destinations and speeds (random waypoint) or mean
        headings (Gauss-Markov), drawn from ``rng``."""
        num_envs, num_users = self.shape
        if self.mobility.model == "random-waypoint":
            self.pause_s = np.zeros(self.shape)
            self.destination_m = np.empty((*self.shape, 2))
            self.speed_mps = np.empty(self.shape)
            self._new_legs(np.ones(self.shape, dtype=bool),
                           uniforms(rng, num_envs, (num_users, 3)), pause=False)
        else:
            heading = 2 * np.pi * uniforms(rng, num_envs, (num_users,))
            self.heading_rad, self.mean_heading_rad = heading, heading.copy()
            self.speed_mps = np.full(self.shape, float(self.mobility.mean_speed_mps))

    def _new_legs(self, chosen: BoolArray, draws: FloatArray, pause: bool = True) -> None:
        """For the ``chosen`` users: a destination and speed from ``draws`` (..., 3 or 4)
        (and a pause, the fourth)."""
        m = self.mobility
        destination = self.half_m * (2 * draws[..., :2] - 1)
        speed = m.speed_min_mps + (m.speed_max_mps - m.speed_min_mps) * draws[..., 2]
        self.destination_m[chosen] = destination[chosen]
        self.speed_mps[chosen] = speed[chosen]
        if pause:
            self.pause_s[chosen] = (m.pause_max_s * draws[..., 3])[chosen]

    # ---- a step ------------------------------------------------------------------------------

    def moved(self, users_m: FloatArray, rng: Generators) -> FloatArray:
        """The users' positions (B, N, 2) one step after ``users_m``, the step's numbers
        drawn from ``rng`` (module doc)."""
        if self.mobility.model == "random-waypoint":
            return self._waypoint_step(users_m, rng)
        return self._gauss_markov_step(users_m, rng)

    def _waypoint_step(self, users_m: FloatArray, rng: Generators) -> FloatArray:
        num_envs, num_users = self.shape
        self._draws = draws = uniforms(rng, num_envs, (num_users, 4))
        pausing = self.pause_s > 0
        self.pause_s = np.maximum(self.pause_s - self.step_s, 0.0)
        offset = self.destination_m - users_m
        distance = np.hypot(offset[..., 0], offset[..., 1])
        travel = self.speed_mps * self.step_s
        arrive = ~pausing & (distance <= travel)
        walking = ~pausing & ~arrive
        step = offset * (travel / np.where(walking, distance, 1.0))[..., None]
        moved = np.where(walking[..., None], users_m + step,
                         np.where(arrive[..., None], self.destination_m, users_m))
        self._new_legs(arrive, draws)
        return moved

    def _gauss_markov_step(self, users_m: FloatArray, rng: Generators) -> FloatArray:
        m = self.mobility
        num_envs, num_users = self.shape
        noise = normals(rng, num_envs, (num_users, 2))
        a, spread = m.memory, math.sqrt(1 - m.memory ** 2)
        self.speed_mps = (a * self.speed_mps + (1 - a) * m.mean_speed_mps
                          + spread * m.speed_sigma_mps * noise[..., 0])
        self.heading_rad = (a * self.heading_rad + (1 - a) * self.mean_heading_rad
                            + spread * math.radians(m.heading_sigma_deg) * noise[..., 1])
        travel = self.speed_mps * self.step_s
        x, x_mirrored = reflected(users_m[..., 0] + travel * np.cos(self.heading_rad),
                                  self.half_m)
        y, y_mirrored = reflected(users_m[..., 1] + travel * np.sin(self.heading_rad),
                                  self.half_m)
        for heading in (self.heading_rad, self.mean_heading_rad):
            heading[x_mirrored] = np.pi - heading[x_mirrored]
            heading[y_mirrored] = -heading[y_mirrored]
        return np.stack([x, y], axis=-1)

    def blocked(self, users: BoolArray) -> None:
        """The ``users`` (B, N) whose step was undone (it ended on a footprint): a new leg
        (random waypoint, from the step's draws), or a turn (Gauss-Markov)."""
        if not users.any():
            return
        if self.mobility.model == "random-waypoint":
            assert self._draws is not None
            self._new_legs(users, self._draws)
        else:
            self.heading_rad[users] += np.pi
            self.mean_heading_rad[users] += np.pi
