"""The package's layers (docs/architecture.md): imports go one way, down the layers

    clbrdf (the public namespace) -> cli -> studies -> tables -> api -> runtime -> ref -> models
                                                                                 -> version

and never in a cycle, with every import of a clbrdf module at the top of its module (an import
inside a function would hide a cycle). Read from the source with ``ast``: nothing is imported."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "clbrdf"
LAYERS = ["version", "models", "ref", "runtime", "api", "tables", "studies", "cli"]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer(mod: str) -> int:
    """The rank of a module: the top-level namespace (clbrdf, clbrdf.__main__) above all."""
    parts = mod.split(".")
    if len(parts) == 1 or parts[1] == "__main__":
        return len(LAYERS)
    return LAYERS.index(parts[1])


def modules() -> dict:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports(path: Path, mod: str):
    """(imported module, line, inside a function) for every import of a clbrdf module."""
    tree = ast.parse(path.read_text(), str(path))
    package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
    known = modules()
    out = []

    def visit(node, in_function):
        for ch in ast.iter_child_nodes(node):
            inner = in_function or isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                   ast.Lambda))
            targets = []
            if isinstance(ch, ast.Import):
                targets = [a.name for a in ch.names]
            elif isinstance(ch, ast.ImportFrom):
                if ch.level:
                    base = package.split(".")[:len(package.split(".")) - ch.level + 1]
                    base = ".".join(base + ([ch.module] if ch.module else []))
                else:
                    base = ch.module or ""
                # "from . import x" and "from .pkg import mod" name modules; else the module
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base
                           for a in ch.names]
            for t in targets:
                if t == "clbrdf" or t.startswith("clbrdf."):
                    out.append((t, ch.lineno, in_function))
            visit(ch, inner)
    visit(tree, False)
    return out


def graph() -> dict:
    return {mod: imports(path, mod) for mod, path in modules().items()}


def test_the_layers_cover_the_package():
    """Every subpackage and module is in a layer (a new folder is placed on purpose)."""
    for mod in modules():
        layer(mod)


def test_no_import_inside_a_function():
    bad = [f"{m}:{line} imports {t}" for m, edges in graph().items()
           for t, line, local in edges if local]
    assert not bad, "\n".join(bad)


def test_imports_go_down_the_layers():
    bad = [f"{m}:{line} imports {t}" for m, edges in graph().items()
           for t, line, _ in edges if layer(t) > layer(m)]
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    g = {m: sorted({t for t, _, _ in edges if t != m}) for m, edges in graph().items()}
    # importing a module runs its packages' __init__ first: an edge to each of those that is
    # not a package of the importer itself
    for m in list(g):
        own = {".".join(m.split(".")[:k]) for k in range(1, m.count(".") + 2)}
        for t in list(g[m]):
            parts = t.split(".")
            g[m] = sorted(set(g[m]) | {".".join(parts[:k]) for k in range(1, len(parts))} - own)
    state, stack = {}, []

    def dfs(m):
        state[m] = 1
        stack.append(m)
        for t in g.get(m, ()):
            if state.get(t) == 1:
                cycle = stack[stack.index(t):] + [t]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if t not in state:
                dfs(t)
        stack.pop()
        state[m] = 2
    for m in sorted(g):
        if m not in state:
            dfs(m)
