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

from adaptsky.channels.contract import (
    DEFAULT_CARRIER_HZ,
    ChannelModel,
    LinkGeometry,
    contract_version_of,
)
from adaptsky.channels.registry import get_model_class
from adaptsky.scenario.models import Scenario
from adaptsky.sim.fading import FadingStage

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def build_channel(scenario: Scenario) -> ChannelModel:
    """The scenario's channel-model plugin with its parameters."""
    model_class = get_model_class(scenario.channel.model)
    return model_class(model_class.Params.model_validate(scenario.channel.params))


def carrier_hz(scenario: Scenario) -> float:
    """f_c of the scenario (``radio.carrier_hz``, resolved when the scenario is loaded)."""
    value = scenario.radio.carrier_hz
    return DEFAULT_CARRIER_HZ if value is None else value


def fading_active(channel: ChannelModel) -> bool:
    """Whether the environment draws per-step fading from this model (contract 2 and its
    ``fading_enabled()``)."""
    return contract_version_of(channel) >= 2 and bool(channel.fading_enabled())


def deterministic_gain(channel: ChannelModel, los: str, geometry: LinkGeometry) -> FloatArray:
    """The gain planning uses: the LoS gain for ``los = "always"``, the LoS or NLoS gain by
    the buildings for ``"geometric"`` (the geometry's ``los``, docs/model.md §12), else the
    expected gain (never with fading)."""
    if los == "always":
        return channel.gain_los(geometry)
    if los == "geometric":
        return geometric_gain(channel, geometry)
    return channel.expected_gain(geometry)


def geometric_gain(channel: ChannelModel, geometry: LinkGeometry) -> FloatArray:
    """The LoS gain of the links the buildings leave in sight, the NLoS gain of the others
    (docs/model.md §12), by the geometry's ``los`` (contract 3)."""
    if geometry.los is None:
        raise ValueError("geometric LoS needs the links' LoS states (LinkGeometry.los)")
    return np.where(geometry.los, channel.gain_los(geometry), channel.gain_nlos(geometry))


def links_geometry(uav_m: FloatArray, users_m: FloatArray, *,
                   user_height_m: float | FloatArray, carrier_hz: float, bandwidth_hz: float,
                   repeated_users_m: FloatArray | None = None) -> LinkGeometry:
    """The geometry stage: the (B*U, N) geometry of the links from UAVs ``uav_m`` (B, U, 3)
    [x, y, h], m, to the users ``users_m`` (B, N, 2) [x, y], m, of their environment; row
    b U + u holds UAV u of environment b (docs/model.md §2, eq. 1 and §9).

    The numbers of :meth:`LinkGeometry.between` on the flattened links
    (:func:`offsets_geometry` of the offsets laid out (B, U, N)); ``user_height_m`` is a
    number or every link's (B*U, N), and ``repeated_users_m`` is ``users_m`` repeated U times
    along the first axis (B*U, N, 2), where the caller keeps them from step to step.
    """
    num_envs, num_uavs, _ = uav_m.shape
    n = users_m.shape[1]
    flat = (num_envs * num_uavs, n)
    link_uav_m = np.empty((3, num_envs, num_uavs, n))     # every link's UAV x, y and h
    link_uav_m[...] = np.moveaxis(uav_m, 2, 0)[..., None]
    link_uav_m = link_uav_m.reshape(3, *flat)
    offsets_m = link_uav_m[:2].reshape(2, num_envs, num_uavs, n) - np.moveaxis(
        users_m, 2, 0)[:, :, None, :]
    if isinstance(user_height_m, np.ndarray):
        user_height = user_height_m
    else:
        user_height = np.full(flat, user_height_m, dtype=np.float64)
    if repeated_users_m is None:
        repeated_users_m = np.repeat(users_m, num_uavs, axis=0)
    return offsets_geometry(offsets_m.reshape(2, *flat), link_uav_m[2], user_height,
                            np.reshape(uav_m, (num_envs * num_uavs, 3)), repeated_users_m,
                            carrier_hz=carrier_hz, bandwidth_hz=bandwidth_hz,
                            users_above_ground=bool(user_height.any()))


def offsets_geometry(offsets_m: FloatArray, height_m: FloatArray, user_height_m: FloatArray,
                     uav_m: FloatArray, users_m: FloatArray, *, carrier_hz: float,
                     bandwidth_hz: float, users_above_ground: bool) -> LinkGeometry:
    """The geometry of links (B', N) from the ground offsets between UAV and user
    ``offsets_m`` (2, B', N) [x_UAV - x_i, y_UAV - y_i] (either sign: only their sizes count),
    the UAV heights ``height_m`` and the user antenna heights ``user_height_m`` (B', N) each,
    and the links' UAV and user positions (B', 3) and (B', N, 2): eq. 1's distance and the
    elevation angle (docs/model.md §2), with h - h_UT = h where ``users_above_ground`` is
    False (the same numbers as the subtraction)."""
    return LinkGeometry._from_offsets(
        offsets_m[0], offsets_m[1], height_m, user_height_m, uav_m, users_m, carrier_hz,
        bandwidth_hz, height_m - user_height_m if users_above_ground else height_m)


def scenario_geometry(scenario: Scenario, uav_m: FloatArray, users_m: FloatArray
                      ) -> LinkGeometry:
    """The links between UAVs ``uav_m`` (B', 3) and users ``users_m`` (B', N, 2) in
    ``scenario`` (its user height, carrier and bandwidth; docs/plugins.md, the geometry):
    :func:`links_geometry` with one UAV per row."""
    return links_geometry(np.asarray(uav_m, dtype=np.float64)[:, None],
                          np.asarray(users_m, dtype=np.float64),
                          user_height_m=scenario.users.height_m,
                          carrier_hz=carrier_hz(scenario),
                          bandwidth_hz=scenario.radio.bandwidth_hz)


Generators = np.random.Generator | list[np.random.Generator] | None


def link_gains(channel: ChannelModel, los_mode: str, geometry: LinkGeometry,
               rng: Generators = None, *, num_uavs: int = 1, fading: bool | None = None,
               small_scale: FadingStage | None = None
               ) -> tuple[FloatArray, BoolArray, FloatArray]:
    """Linear gain of one antenna pair, LoS state and LoS probability of every link, each
    (B, U, N), from a (B*U, N) ``geometry``: :func:`link_gains_and_means` without the
    large-scale gains."""
    return link_gains_and_means(channel, los_mode, geometry, rng, num_uavs=num_uavs,
                                fading=fading, small_scale=small_scale)[:3]


def link_gains_and_means(channel: ChannelModel, los_mode: str, geometry: LinkGeometry,
                         rng: Generators = None, *, num_uavs: int = 1,
                         fading: bool | None = None, small_scale: FadingStage | None = None
                         ) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray]:
    """Linear gain of one antenna pair, LoS state, LoS probability and large-scale gain (the
    gain before any fading: its mean, docs/model.md §16) of every link, each (B, U, N), from
    a (B*U, N) ``geometry`` (:func:`links_geometry`).

    ``los_mode`` (docs/model.md §2): ``"always"`` the LoS gain; ``"sampled"`` LoS drawn per
    link (the plugin's ``sample_los``), the LoS or NLoS gain; ``"expected"``
    P g_LoS + (1 - P) g_NLoS (LoS state: P > 0.5); ``"geometric"`` the LoS or NLoS gain by
    the buildings (the geometry's ``los``, docs/model.md §12; its P_LoS is 1 or 0). A
    contract-2 model with fading enabled multiplies the gain by its ``sample_fading``, drawn
    after the LoS states. Draws come from
    ``rng``: one generator for every link, or a list of B, environment b's links (U rows)
    drawn from generator b (so its numbers do not depend on B or on its neighbours).
    ``fading``: :func:`fading_active` of the channel where the caller has it.
    ``small_scale``: the built-in fading (docs/model.md §11), drawn after the LoS states
    (every link's, LoS or not, so that its draws do not depend on them), its ``|h|^2``
    multiplying every link's gain.
    """
    if los_mode == "geometric":
        gain, los = geometric_gain(channel, geometry), geometry.los
        assert los is not None
        p_los = los.astype(np.float64)
    else:
        gain, los, p_los = _drawn_los(channel, los_mode, geometry, rng, num_uavs)
    large_scale = gain
    if fading_active(channel) if fading is None else fading:
        gain = gain * _drawn(channel.sample_fading, geometry, los, rng, num_uavs)
    if small_scale is not None:
        if rng is None:
            raise ValueError("fading draws from a generator; pass rng")
        factors = small_scale.power_gains(geometry.elevation_deg,
                                          None if los_mode == "always" else los, rng)
        gain = np.multiply(gain, factors, out=factors)
    shape = (geometry.shape[0] // num_uavs, num_uavs, geometry.shape[1])
    return (gain.reshape(shape), los.reshape(shape), p_los.reshape(shape),
            large_scale.reshape(shape))


def _drawn_los(channel: ChannelModel, los_mode: str, geometry: LinkGeometry,
               rng: Generators, num_uavs: int) -> tuple[FloatArray, BoolArray, FloatArray]:
    """Gain, LoS state and P_LoS of every link (B*U, N) by the model's LoS probability
    (``los_mode`` always, sampled or expected; :func:`link_gains`)."""
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
        if type(channel).expected_gain is ChannelModel.expected_gain:
            # the base class's P g_LoS + (1 - P) g_NLoS, with the P_LoS at hand
            gain = p_los * channel.gain_los(geometry) + (1 - p_los) * channel.gain_nlos(
                geometry)
        else:
            gain = channel.expected_gain(geometry)
        los = p_los > 0.5
    else:
        raise ValueError(f"unknown LoS mode {los_mode!r}; use always, sampled, expected or "
                         "geometric")
    return gain, los, p_los


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
