"""The layout of the tests themselves (tests/README.md): no test module imports another test
module; what several modules share lives in ``tests/helpers/`` or a conftest; no test checks
only that a time is not negative."""

from __future__ import annotations

import ast
import re
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def _imported_modules(path: Path) -> list[tuple[int, str]]:
    """Every module ``path`` imports, at any depth (imports inside functions count too)."""
    imported = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            imported += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            imported.append((node.lineno, node.module))
            imported += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            raise AssertionError(f"{path}:{node.lineno}: a relative import; import tests.…")
    return imported


def test_no_test_module_imports_another_test_module():
    found = [f"{path.relative_to(TESTS.parent)}:{line}: {module}"
             for path in sorted(TESTS.rglob("*.py"))
             for line, module in _imported_modules(path)
             if module.startswith("tests.") and module.split(".")[-1].startswith("test_")]
    assert not found, "move the shared names into tests/helpers/:\n" + "\n".join(found)


def test_helpers_are_not_collected_as_tests():
    assert not list((TESTS / "helpers").glob("test_*.py"))


def test_no_test_asserts_only_that_a_time_is_not_negative():
    """A time a test checks is bounded by something that could fail (the time the test
    measured around it, say), never only ``>= 0``, which every clock passes."""
    time_at_least_0 = re.compile(r"^\s*assert .*(second|_s\b|wall|elapsed).*>= ?0(?![.\d])")
    found = [f"{path.relative_to(TESTS.parent)}:{number}: {line.strip()}"
             for path in sorted(TESTS.rglob("*.py"))
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if time_at_least_0.search(line)]
    assert not found, "bound these times by what the test measured:\n" + "\n".join(found)
