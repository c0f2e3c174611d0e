"""No module of adaptsky or adaptsky_cli uses another module's private names (issue 53, item 2):
no ``from X import _name`` and no ``X._name`` on an imported module X of the project. A name
several modules share is public, under a name that says what it is."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("adaptsky", "adaptsky_cli")


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _is_module(name: str) -> bool:
    """Whether the dotted ``name`` is a module or package of the project."""
    base = ROOT.joinpath(*name.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _source_module(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The absolute module an ImportFrom reads from, relative imports resolved."""
    if not node.level:
        return node.module or ""
    parts = module.split(".") if is_package else module.split(".")[:-1]
    parts = parts[:len(parts) - node.level + 1]
    return ".".join([*parts, *([node.module] if node.module else [])])


def _dotted(node: ast.expr) -> list[str] | None:
    """``a.b.c`` as ["a", "b", "c"]; None for anything but names and attributes."""
    parts: list[str] = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    return [node.id, *reversed(parts)] if isinstance(node, ast.Name) else None


def private_uses(source: str, module: str, is_package: bool = False) -> list[str]:
    """Each use, in the code ``source`` of ``module``, of another project module's private
    name: ``line: text``."""
    tree = ast.parse(source)
    modules: dict[str, str] = {}      # a local name -> the project module it is bound to
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in PACKAGES:
                    local = alias.asname or alias.name.split(".")[0]
                    modules[local] = alias.name if alias.asname else local
        elif isinstance(node, ast.ImportFrom):
            origin = _source_module(node, module, is_package)
            if origin.split(".")[0] not in PACKAGES:
                continue
            for alias in node.names:
                if _private(alias.name) and origin != module:
                    found.append(f"{node.lineno}: from {origin} import {alias.name}")
                elif _is_module(f"{origin}.{alias.name}"):
                    modules[alias.asname or alias.name] = f"{origin}.{alias.name}"
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and _private(node.attr)):
            continue
        chain = _dotted(node.value)
        if chain is None or chain[0] not in modules:
            continue
        owner = ".".join([modules[chain[0]], *chain[1:]])
        if _is_module(owner) and owner != module:
            found.append(f"{node.lineno}: {'.'.join(chain)}.{node.attr} ({owner})")
    return found


def test_no_module_uses_another_modules_private_names():
    found = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            is_package = parts[-1] == "__init__"
            module = ".".join(parts[:-1] if is_package else parts)
            found += [f"{path.relative_to(ROOT)}:{use}"
                      for use in private_uses(path.read_text(), module, is_package)]
    assert not found, ("make these names public (a name that says what it is) or keep them in "
                       "their module:\n" + "\n".join(found))


def test_the_walk_finds_each_form():
    source = "\n".join([
        "from adaptsky.rollouts.oracle import _hidden, lattice",
        "from .oracle import _relative",
        "from adaptsky.rollouts import oracle",
        "import adaptsky.rollouts.oracle as orc",
        "import adaptsky.rollouts.oracle",
        "from adaptsky.rollouts.oracle import lattice as grid",
        "from numpy import _private_of_numpy",
        "oracle._a(); orc._b(); adaptsky.rollouts.oracle._c(); grid._attribute_of_a_function",
        "oracle.lattice(); oracle.__name__",
    ])
    assert private_uses(source, "adaptsky.rollouts.genie") == [
        "1: from adaptsky.rollouts.oracle import _hidden",
        "2: from adaptsky.rollouts.oracle import _relative",
        "8: oracle._a (adaptsky.rollouts.oracle)",
        "8: orc._b (adaptsky.rollouts.oracle)",
        "8: adaptsky.rollouts.oracle._c (adaptsky.rollouts.oracle)",
    ]
    # a module's own private names are its own
    assert private_uses("from adaptsky.rollouts.oracle import _hidden\n",
                        "adaptsky.rollouts.oracle") == []
    # a package's __init__ resolves relative imports from itself
    assert private_uses("from .oracle import _x\n", "adaptsky.rollouts", is_package=True) == [
        "1: from adaptsky.rollouts.oracle import _x"]
