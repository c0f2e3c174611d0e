"""Channel-model plugins for the plugin tests: a good model, broken module texts, fake
distributions as pip leaves them, the plugin guide's code blocks."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import numpy as np

from adaptsky.channels import ChannelModel
from tests.conftest import ROOT


def fake_distribution(root: Path, name: str, module_text: str) -> None:
    """A plugin distribution on ``root`` (a dist-info folder and its module), as pip leaves it."""
    module = name.replace("-", "_")
    (root / f"{module}.py").write_text(textwrap.dedent(module_text))
    info = root / f"{module}-0.3.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.3\n")
    (info / "entry_points.txt").write_text(
        f"[adaptsky.channel_models]\n{name} = {module}:Model\n")


class Good(ChannelModel):
    description = "free space at 28 GHz, always LoS"

    def los_probability(self, geometry):
        return np.ones(geometry.shape)

    def gain_los(self, geometry):
        return (299_792_458.0 / (4 * np.pi * 28e9 * geometry.distance_m)) ** 2

    def gain_nlos(self, geometry):
        return 0.1 * self.gain_los(geometry)


MISSING = """\
    import numpy as np
    from adaptsky.channels import ChannelModel

    class Model(ChannelModel):
        description = "forgets gain_nlos"
        def los_probability(self, geometry):
            return np.ones(geometry.shape)
        def gain_los(self, geometry):
            return 1.0 / geometry.distance_m ** 2
    """


GUIDE = ROOT / "docs" / "plugins.md"
# every fenced block of docs/plugins.md, by what it is; each is run (or, for the layout, built)
# by the tests below, and a block that none of these names fails the first test
GUIDE_BLOCKS = {
    "entry point": lambda lang, text: lang == "toml" and text.startswith("[project.entry"),
    "imports": lambda lang, text: lang == "python" and text.startswith("from adaptsky.channels"),
    "fading": lambda lang, text: lang == "python" and "class FreeSpaceFading" in text,
    "layout": lambda lang, text: lang == "" and text.startswith("adaptsky-free-space/"),
    "module": lambda lang, text: lang == "python" and text.startswith('"""Free-space channel'),
    "pyproject": lambda lang, text: lang == "toml" and "[project]" in text,
    "scenario": lambda lang, text: lang == "toml" and 'model = "free-space"' in text,
    "commands": lambda lang, text: lang == "sh" and "adaptsky plugins check" in text,
    "tests": lambda lang, text: lang == "python" and "def test_matches_friis" in text,
    "default radio": lambda lang, text: lang == "python" and "default_radio =" in text,
    # section 9, run by tests/unit/channels/test_subclass_builtin.py
    "subclass": lambda lang, text: lang == "python" and "class DenseNyc(MmWaveNyc)" in text,
}


def guide_block(kind: str) -> str:
    return next(text for lang, text in guide_blocks() if GUIDE_BLOCKS[kind](lang, text))


def guide_blocks() -> list[tuple[str, str]]:
    return re.findall(r"^```(\w*)\n(.*?)^```", GUIDE.read_text(), flags=re.DOTALL | re.MULTILINE)


UNDECLARED = textwrap.dedent(MISSING) + """\
    def gain_nlos(self, geometry):
        return 0.1 / geometry.distance_m ** 2
"""  # complete, written before contract versions
