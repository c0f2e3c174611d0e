"""Channel models: the plugin contract, geometry helpers and entry-point discovery."""

from adaptsky.channels.contract import (
    ChannelModel,
    ChannelParams,
    LinkGeometry,
    Supports,
    db_to_linear,
    free_space_gain,
)

__all__ = ["ChannelModel", "ChannelParams", "LinkGeometry", "Supports", "db_to_linear",
           "free_space_gain"]
