"""The package's layout, read from its source with ``ast``: the data path runs one way.

surfaces → operators → normal → tangential → analysis → farm: a package may
import the ones below it and the shared top-level modules, never one above;
no import circle closes inside a package (lazy imports inside functions
count: they hide a circle, they do not remove it); no module reaches into
another package's private module; the shared base modules import no package.
And docs/api.md lists each public package's ``__all__``, once, so the
documented names cannot drift from the code.
"""
from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "roughcontact"
#: the data path, bottom to top
FLOORS = ("surfaces", "operators", "normal", "tangential", "analysis", "farm", "paper")
#: top-level modules every package may use; they import no subpackage
BASE = ("errors", "checks", "collective", "petsc", "netcdf", "materials")
#: packages whose public names docs/api.md lists
DOCUMENTED = ("normal", "tangential", "analysis", "farm", "paper")


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package's __init__)."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return out


MODULES = _modules()


def _targets(name: str, is_package: bool, node: ast.AST) -> list[str]:
    """The package modules an import statement of module ``name`` loads."""
    if isinstance(node, ast.Import):
        candidates = [alias.name for alias in node.names]
    else:
        if node.level:
            base = name.split(".") if is_package else name.split(".")[:-1]
            base = base[: len(base) - node.level + 1]
            prefix = ".".join(base + ([node.module] if node.module else []))
        else:
            prefix = node.module or ""
        candidates = [f"{prefix}.{a.name}" if f"{prefix}.{a.name}" in MODULES else prefix for a in node.names]
    out = []
    for target in candidates:
        while target and target not in MODULES:
            target = target.rpartition(".")[0]
        if target.startswith("roughcontact"):
            out.append(target)
    return out


def _graph() -> dict[str, set[str]]:
    graph = defaultdict(set)
    for name, (path, is_package) in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                graph[name].update(t for t in _targets(name, is_package, node) if t != name)
    return graph


GRAPH = _graph()


def _package(module: str) -> str:
    """``roughcontact.normal`` for any module inside it; the module itself at the top level."""
    parts = module.split(".")
    return ".".join(parts[:2])


def _cycles(nodes: list[str], edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in nodes:
        if v not in index:
            visit(v)
    return found


def test_the_walk_sees_the_package():
    """The walk itself: it finds the known modules and a known edge (a broken walk would pass all else)."""
    assert {"roughcontact.normal.factory", "roughcontact.farm.run", "roughcontact.checks"} <= set(MODULES)
    assert "roughcontact.normal.choice" in GRAPH["roughcontact.normal.factory"]
    assert "roughcontact.normal.constrained_cg" in GRAPH["roughcontact.normal.factory"]


@pytest.mark.parametrize("package", sorted({_package(m) for m, (_, is_pkg) in MODULES.items() if is_pkg}))
def test_no_import_circle_inside_a_package(package):
    """Modules of one package (its __init__ aside, which only re-exports) form no import circle."""
    inside = [m for m, (_, is_pkg) in MODULES.items() if m.startswith(package + ".") and not is_pkg]
    edges = {m: {t for t in GRAPH[m] if t in inside} for m in inside}
    assert _cycles(inside, edges) == []


def test_no_private_module_across_packages():
    """A module named ``_x`` is imported only from inside its own package."""
    offenders = [(m, t) for m, targets in GRAPH.items() for t in targets
                 if t.rpartition(".")[2].startswith("_") and not t.endswith("__init__")
                 and _package(t) != _package(m)]
    assert offenders == []


def test_packages_import_only_downwards():
    """A package imports the floors below it, never one above (the data path runs one way)."""
    offenders = []
    for module, targets in GRAPH.items():
        here = module.split(".")[1] if module.count(".") >= 1 else ""
        for target in targets:
            there = target.split(".")[1] if target.count(".") >= 1 else ""
            if here in FLOORS and there in FLOORS and FLOORS.index(there) > FLOORS.index(here):
                offenders.append((module, target))
    assert offenders == []


def test_base_modules_import_no_package():
    """errors, checks, collective, petsc, netcdf, materials sit under every floor."""
    offenders = [(f"roughcontact.{b}", t) for b in BASE for t in GRAPH[f"roughcontact.{b}"]
                 if t.split(".")[1] not in BASE]
    assert offenders == []


def _public_names(package: str) -> list[str]:
    tree = ast.parse((PACKAGE / package / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise AssertionError(f"roughcontact.{package} has no __all__")


@pytest.mark.parametrize("package", DOCUMENTED)
def test_docs_list_the_public_names_once(package):
    """docs/api.md has a section per package listing exactly its __all__, each name once."""
    text = (ROOT / "docs" / "api.md").read_text()
    match = re.search(rf"^## `roughcontact\.{package}`\n(.*?)(?=^## |\Z)", text, re.M | re.S)
    assert match, f"docs/api.md has no section for roughcontact.{package}"
    listed = re.findall(r"^- `(\w+)`", match.group(1), re.M)
    assert sorted(listed) == sorted(_public_names(package))
    assert len(listed) == len(set(listed))
