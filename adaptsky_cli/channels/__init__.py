"""Alias of :mod:`adaptsky.channels` for channel-model plugins written against
``adaptsky_cli.channels`` (before the library moved to ``adaptsky``): the same modules, so the
same classes, under the old names. New plugins import ``adaptsky.channels`` (docs/plugins.md).
"""

import sys

import adaptsky.channels
from adaptsky.channels import checker, contract, registry

for _module in (checker, contract, registry):
    sys.modules[f"{__name__}.{_module.__name__.rsplit('.', 1)[1]}"] = _module
sys.modules[__name__] = adaptsky.channels
