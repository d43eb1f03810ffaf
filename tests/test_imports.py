"""The package's import structure: every module imports in a fresh interpreter, and the library
modules import one another without a cycle (a module never needs, even inside a function, a
module that needs it back), so that the stages stack: the layout below the kinematics, the
kinematics below the dynamics, the compiled kernels beside the numpy solvers they mirror.

The graph is read from the source with ``ast``: every ``import`` statement of a module, at
module level or inside a function (a deferred import hides a cycle, it does not remove it),
except those under ``if TYPE_CHECKING:``. ``from package import name`` counts as an import of
the submodule ``package.name`` where that is a module, else of the package itself. The command
line (``linkdyn.cli`` and the commands it registers from ``linkdyn.studies.cli``) sits above the
library: no library module imports it, and it is left out of the cycle check.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import linkdyn

ROOT = Path(linkdyn.__file__).resolve().parent
CLI = {"linkdyn.cli", "linkdyn.studies.cli"}


def modules() -> dict[str, tuple[Path, list[str]]]:
    """Every module of the package: its dotted name -> (file, the package it sits in, split)."""
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
            package = parts
        else:
            package = parts[:-1]
        out[".".join(parts)] = (path, package)
    return out


def _type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def imports(name: str, path: Path, package: list[str], known) -> set[str]:
    """The modules of the package that module ``name`` imports anywhere in its source."""
    found = set()
    skip = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if _type_checking(node):
            skip.update(id(n) for n in ast.walk(node))
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            subs = [f"{target}.{a.name}" for a in node.names]
            hits = [s for s in subs if s in known]
            if len(hits) < len(subs):   # a name defined in the module ``target`` itself
                hits.append(target)
            found.update(hits)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return {m for m in found if m in known and m != name}


def graph() -> dict[str, set[str]]:
    known = modules()
    return {name: imports(name, path, package, known) for name, (path, package) in known.items()}


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm,
    iterative), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []
    for root in sorted(g):
        if root in index:
            continue
        work = [(root, iter(sorted(g[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(g[w]))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def test_the_cycle_finder_finds_a_cycle():
    """(The check below can fail.) A three-module ring and a pair are found, a chain is not."""
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d", "f"}, "f": set()}
    assert sorted(cycles(g)) == [["a", "b", "c"], ["d", "e"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_the_graph_reads_deferred_and_relative_imports():
    g = graph()
    # a module-level relative import of a submodule, and one of a name from a package
    assert "linkdyn.kinematics.layout" in g["linkdyn.kinematics.recursion"]
    assert "linkdyn.errors" in g["linkdyn.analysis"]
    # a deferred import inside a function counts
    assert "linkdyn.io" in g["linkdyn.analysis"]


def test_no_import_cycle_among_the_library_modules():
    g = graph()
    library = {m: deps - CLI for m, deps in g.items() if m not in CLI}
    assert cycles(library) == []


def test_no_library_module_imports_the_command_line():
    g = graph()
    assert {m: sorted(d & CLI) for m, d in g.items() if m not in CLI and d & CLI} == {}


def test_every_module_imports_in_a_fresh_interpreter():
    names = [m for m in sorted(modules()) if not m.endswith("__main__")]
    code = "import importlib, sys\nfor m in sys.argv[1:]:\n    importlib.import_module(m)\n"
    res = subprocess.run([sys.executable, "-c", code, *names], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr
