"""The layout of the tests themselves (tests/README.md): no test module imports another test
module; what several modules share lives in ``tests/helpers/`` or a conftest."""

from __future__ import annotations

import ast
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
