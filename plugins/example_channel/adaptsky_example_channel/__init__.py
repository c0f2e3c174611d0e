"""Example third-party adaptsky channel plugin: the 3GPP TR 36.777 UMa-AV channel.

Registered under the entry-point group ``adaptsky.channel_models`` as ``uma-av``.
"""

from adaptsky_example_channel.uma_av import UmaAv, UmaAvParams

__all__ = ["UmaAv", "UmaAvParams"]
