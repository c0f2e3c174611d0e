"""Gains of the links from every UAV to every user (docs/model.md §2 and §9), for B
environments of U UAVs and N users.

The channel-model plugins see B U independent (UAV, N users) geometries: the links are
flattened to a (B*U, N) :class:`~adaptsky.channels.contract.LinkGeometry`, so every plugin
works unchanged; the gains come back as (B, U, N).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import ChannelModel, LinkGeometry, contract_version_of

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def all_links_geometry(uav_m: FloatArray, users_m: FloatArray, *, user_height_m: float,
                       carrier_hz: float, bandwidth_hz: float) -> LinkGeometry:
    """The (B*U, N) geometry of the links from UAVs ``uav_m`` (B, U, 3) [x, y, h], m, to the
    users ``users_m`` (B, N, 2) [x, y], m, of their environment: row b U + u holds UAV u of
    environment b."""
    num_envs, num_uavs, _ = uav_m.shape
    flat_uav_m = np.reshape(uav_m, (num_envs * num_uavs, 3))
    flat_users_m = np.repeat(users_m, num_uavs, axis=0)
    return LinkGeometry.between(flat_uav_m, flat_users_m, user_height_m=user_height_m,
                                carrier_hz=carrier_hz, bandwidth_hz=bandwidth_hz)


Generators = np.random.Generator | list[np.random.Generator] | None


def link_gains(channel: ChannelModel, los_mode: str, geometry: LinkGeometry,
               rng: Generators = None, *, num_uavs: int = 1
               ) -> tuple[FloatArray, BoolArray, FloatArray]:
    """Linear gain of one antenna pair, LoS state and LoS probability of every link, each
    (B, U, N), from a (B*U, N) ``geometry`` (:func:`all_links_geometry`).

    ``los_mode`` (docs/model.md §2): ``"always"`` the LoS gain; ``"sampled"`` LoS drawn per
    link (the plugin's ``sample_los``), the LoS or NLoS gain; ``"expected"``
    P g_LoS + (1 - P) g_NLoS (LoS state: P > 0.5). A contract-2 model with fading enabled
    multiplies the gain by its ``sample_fading``, drawn after the LoS states. Draws come from
    ``rng``: one generator for every link, or a list of B, environment b's links (U rows)
    drawn from generator b (so its numbers do not depend on B or on its neighbours).
    """
    p_los = channel.los_probability(geometry)
    if los_mode == "always":
        gain, los = channel.gain_los(geometry), np.ones(geometry.shape, dtype=bool)
    elif los_mode == "sampled":
        if type(channel).sample_los is ChannelModel.sample_los:
            # the base class's draw, one uniform per link below P_LoS, with the P_LoS at hand
            los = _uniforms(geometry.shape, rng, num_uavs) < p_los
        else:
            los = _drawn(lambda rows, _, r: channel.sample_los(rows, r), geometry, None, rng,
                         num_uavs)
        gain = np.where(los, channel.gain_los(geometry), channel.gain_nlos(geometry))
    elif los_mode == "expected":
        gain, los = channel.expected_gain(geometry), p_los > 0.5
    else:
        raise ValueError(f"unknown LoS mode {los_mode!r}; use always, sampled or expected")
    if contract_version_of(channel) >= 2 and channel.fading_enabled():
        gain = gain * _drawn(channel.sample_fading, geometry, los, rng, num_uavs)
    shape = (geometry.shape[0] // num_uavs, num_uavs, geometry.shape[1])
    return gain.reshape(shape), los.reshape(shape), p_los.reshape(shape)


def _uniforms(shape: tuple[int, ...], rng: Generators, num_uavs: int) -> FloatArray:
    """Uniform draws in [0, 1) of every link (B*U, N): ``rng.random(shape)``, or with a list
    of generators environment b's ``num_uavs`` rows from generator b, the numbers
    ``ChannelModel.sample_los`` draws from it for those rows (written in place, without a
    geometry per environment)."""
    if rng is None:
        raise ValueError("sampled LoS and fading draw from a generator; pass rng")
    if not isinstance(rng, list):
        return rng.random(shape)
    draws = np.empty(shape)
    for b, generator in enumerate(rng):
        generator.random(out=draws[b * num_uavs:(b + 1) * num_uavs])
    return draws


def _drawn(draw: Callable[[LinkGeometry, Any, np.random.Generator], np.ndarray],
           geometry: LinkGeometry, los: BoolArray | None, rng: Generators, num_uavs: int
           ) -> np.ndarray:
    """``draw(geometry, los, generator)`` over all links, or environment by environment
    (``num_uavs`` rows each) with a list of generators."""
    if rng is None:
        raise ValueError("sampled LoS and fading draw from a generator; pass rng")
    if not isinstance(rng, list):
        return draw(geometry, los, rng)
    return np.concatenate([
        draw(geometry.rows(b * num_uavs, (b + 1) * num_uavs),
             None if los is None else los[b * num_uavs:(b + 1) * num_uavs], generator)
        for b, generator in enumerate(rng)])
