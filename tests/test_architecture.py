"""The package's layers (docs/architecture.md): imports go one way, down the layers

    clbrdf (the public namespace) -> cli -> studies -> tables -> api -> runtime -> ref -> models
                                                                                 -> version

and never in a cycle. Every import of a clbrdf module sits at the top of its module, except in
the command line, where each command imports what it uses inside its function (so that a command
starts at once) and the public namespace, whose names are imported on first use (its ``PUBLIC``
table): those imports are edges of the graph as well, checked for direction and cycles. Read
from the source with ``ast``: nothing is imported."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path


PACKAGE = Path(__file__).resolve().parents[1] / "clbrdf"
LAYERS = ["version", "models", "ref", "runtime", "api", "tables", "studies", "cli"]


def module_name(path: Path, package: Path = PACKAGE) -> str:
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer(mod: str) -> int:
    """The rank of a module: the top-level namespace (clbrdf, clbrdf.__main__) above all."""
    parts = mod.split(".")
    if len(parts) == 1 or parts[1] == "__main__":
        return len(LAYERS)
    return LAYERS.index(parts[1])


def modules(package: Path = PACKAGE) -> dict:
    return {module_name(p, package): p for p in sorted(package.rglob("*.py"))}


def imports(path: Path, mod: str, known: dict):
    """(imported module, line, inside a function) for every import of a clbrdf module."""
    tree = ast.parse(path.read_text(), str(path))
    package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
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
    if mod == "clbrdf":                 # PUBLIC = {name: module}: imported on first use
        for node in tree.body:
            if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Dict)
                    and any(getattr(t, "id", None) == "PUBLIC" for t in node.targets)):
                out += [(v.value, v.lineno, True) for v in node.value.values]
    return out


def graph(package: Path = PACKAGE) -> dict:
    known = modules(package)
    return {mod: imports(path, mod, known) for mod, path in known.items()}


def test_the_layers_cover_the_package():
    """Every subpackage and module is in a layer (a new folder is placed on purpose)."""
    for mod in modules():
        layer(mod)


LAZY = ("clbrdf", "clbrdf.cli")      # where an import inside a function is the rule


def local_imports(g: dict) -> list:
    return [f"{m}:{line} imports {t}" for m, edges in g.items() for t, line, local in edges
            if local and not (m in LAZY or m.startswith("clbrdf.cli."))]


def upward_imports(g: dict) -> list:
    return [f"{m}:{line} imports {t}" for m, edges in g.items() for t, line, _ in edges
            if layer(t) > layer(m)]


def test_no_import_inside_a_function():
    bad = local_imports(graph())
    assert not bad, "\n".join(bad)


def test_imports_go_down_the_layers():
    bad = upward_imports(graph())
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    cycle = find_cycle(graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_the_checks_can_fail(tmp_path):
    """A package with a cycle (models.a <-> models.b), an upward import (runtime -> cli) and an
    import inside a function: each check finds its defect."""
    pkg = tmp_path / "clbrdf"
    for d in ("models", "runtime", "cli"):
        (pkg / d).mkdir(parents=True)
        (pkg / d / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "models" / "a.py").write_text("from . import b\n")
    (pkg / "models" / "b.py").write_text("from . import a\n")
    (pkg / "runtime" / "r.py").write_text("from ..cli import c\n\n\ndef f():\n    from ..models import a\n")
    (pkg / "cli" / "c.py").write_text("")
    g = graph(pkg)
    assert find_cycle(g) is not None
    assert upward_imports(g) == ["clbrdf.runtime.r:1 imports clbrdf.cli.c"]
    assert local_imports(g) == ["clbrdf.runtime.r:5 imports clbrdf.models.a"]


def find_cycle(graph_: dict):
    """A cycle of the import graph as a list of modules, or None."""
    g = {m: sorted({t for t, _, _ in edges if t != m}) for m, edges in graph_.items()}
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
                return stack[stack.index(t):] + [t]
            if t not in state:
                found = dfs(t)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None
    for m in sorted(g):
        if m not in state:
            found = dfs(m)
            if found:
                return found
    return None


def test_nothing_is_computed_at_import():
    """studies.fresnel_fits solved a 2000-point Gauss-Legendre eigenproblem at import, which
    every command paid before it started; the rule is now made on first use."""
    code = ("import clbrdf, clbrdf.cli.main, clbrdf.studies.fresnel_fits as f; "
            "assert f.gauss_rule.cache_info().currsize == 0")
    subprocess.run([sys.executable, "-c", code], check=True)


# what a command that answers at once must not import: each costs 0.1 to 0.5 s here
HEAVY = ("scipy", "matplotlib", "dask", "distributed", "zarr", "pyopencl", "OpenEXR", "tqdm",
         "clbrdf.api", "clbrdf.studies.sweep", "clbrdf.tables.compute")


def test_a_command_that_answers_at_once_imports_nothing_heavy(tmp_path):
    """`clbrdf --version`, `clbrdf models`, `--help` and bad input (an unknown model, a missing
    directory) import none of HEAVY: each command imports what it uses (the wall time, under 0.5
    s on an idle machine, is benchmarks/bench_overhead.py's --startup)."""
    probe = ("import sys\nfrom clbrdf.cli import main\ntry:\n    rc = main(sys.argv[1:])\n"
             "except SystemExit as e:\n    rc = e.code\n"
             f"heavy = [m for m in sys.modules if m.split('.')[0] in {HEAVY!r} or "
             f"any(m == h or m.startswith(h + '.') for h in {HEAVY!r})]; "
             "print('HEAVY', sorted(heavy)); sys.exit(rc)")
    for argv, rc in ((["--version"], 0), (["models"], 0), (["table", "--help"], 0),
                     (["table", "nosuchmodel", "--axis", "mu=0:1:4", "--out", "t.npz"], 2),
                     (["layouts"], 0)):
        r = subprocess.run([sys.executable, "-c", probe, *argv], capture_output=True,
                           text=True, cwd=tmp_path)
        assert r.returncode == rc, (argv, r.stderr)
        line = [x for x in r.stdout.splitlines() if x.startswith("HEAVY")]
        assert line == ["HEAVY []"], (argv, line)


def private_imports(package: Path = PACKAGE) -> list:
    """``from M import _name`` of another module's private name (an ``as _alias`` of a public
    name is the importer's own)."""
    bad = []
    for mod, path in modules(package).items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith("clbrdf")):
                bad += [f"{mod}:{node.lineno} imports {a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    return bad


def test_no_module_imports_another_modules_private_names():
    bad = private_imports()
    assert not bad, "\n".join(bad)


def test_the_private_name_check_can_fail(tmp_path):
    pkg = tmp_path / "clbrdf"
    (pkg / "api").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "api" / "__init__.py").write_text("")
    (pkg / "api" / "a.py").write_text("def _f():\n    pass\n")
    (pkg / "api" / "b.py").write_text("from .a import _f\nfrom . import a as _a\n")
    assert private_imports(pkg) == ["clbrdf.api.b:1 imports _f"]


def test_the_tests_folders_mirror_the_packages():
    """tests/ has a folder per layer of the package (docs/architecture.md), holding that layer's
    tests; only the whole-repository tests (architecture, docs, the wheel) and the helpers stay at
    the top, and no test file sits in a folder that is not a layer."""
    tests = Path(__file__).resolve().parent
    folders = {p.name for p in tests.iterdir() if p.is_dir() and not p.name.startswith((".", "_"))}
    assert folders - {"data"} <= set(LAYERS), sorted(folders - {"data"} - set(LAYERS))
    top = sorted(p.name for p in tests.glob("test_*.py"))
    assert top == ["test_architecture.py", "test_docs.py", "test_wheel.py"], top
    assert not list((tests / "data").rglob("test_*.py"))
    assert all(list((tests / f).glob("test_*.py")) for f in folders - {"data"})
