"""``dir(adaptsky)`` shows the public API (docs/install.md "Import names") and nothing of the
helpers the package module uses to provide it."""

from __future__ import annotations

import subprocess
import sys

import adaptsky


def _public(names: list[str]) -> list[str]:
    return [name for name in names if not name.startswith("_")]


def test_dir_lists_the_public_api_and_no_helpers():
    assert _public(dir(adaptsky)) == sorted(_public(adaptsky.__all__))
    assert "__version__" in dir(adaptsky) and "__version__" in adaptsky.__all__


def test_dir_stays_the_public_api_after_names_are_used_and_subpackages_imported():
    code = ("import adaptsky, adaptsky.channels, adaptsky.scenario; adaptsky.load_scenario; "
            "print(' '.join(n for n in dir(adaptsky) if not n.startswith('_')))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True, timeout=60)
    assert result.stdout.split() == sorted(_public(adaptsky.__all__))
