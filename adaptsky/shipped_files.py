"""Files shipped with adaptsky: the paper's experiments and scenarios.

An installed wheel holds them inside the package (``adaptsky/shipped/<kind>``, see
pyproject's force-include); a source checkout (also an editable install) has them in the
repository's top-level folders.
"""

from __future__ import annotations

from pathlib import Path

from adaptsky.errors import ScenarioError

PACKAGE_ROOT = Path(__file__).resolve().parent
DEFAULT_SCENARIO = "nyc_mmwave.toml"   # E3, the paper's mmWave scenario


def shipped_folder(kind: str) -> Path | None:
    """The folder of shipped ``kind`` files (``"experiments"``, ``"scenarios"``), if any."""
    for folder in (PACKAGE_ROOT / "shipped" / kind, PACKAGE_ROOT.parent / kind):
        if folder.is_dir():
            return folder
    return None


def default_scenario_path() -> Path:
    """The shipped scenario an environment uses when given none."""
    folder = shipped_folder("scenarios")
    path = None if folder is None else folder / DEFAULT_SCENARIO
    if path is None or not path.is_file():
        raise ScenarioError([f"{PACKAGE_ROOT / 'shipped' / 'scenarios' / DEFAULT_SCENARIO}: "
                             "the default scenario is missing from this installation; "
                             "reinstall adaptsky or pass scenario=PATH"])
    return path
