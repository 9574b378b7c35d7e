"""Data flows one way (sensors -> human -> limitations -> filter -> integrator -> scene): no
package of ``cobotsafety`` imports one that imports it back, and the core never imports the
layers built on it. Read from the source (every ``import`` statement, lazy ones included)."""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "cobotsafety"
#: Packages the arm core and the human pipeline must never import (they are built on them).
UPPER = {"app", "bench", "cli", "experiments", "tools", "trial"}
CORE = {"arm", "human", "sensors", "geometry", "estimation", "least_distance", "small_linalg", "projection",
        "planar", "teleoperated"}


def imports() -> list[tuple[str, str, str]]:
    """(importing module, imported module, file) for every import of a ``cobotsafety`` module;
    ``from cobotsafety.x import y`` counts as importing ``cobotsafety.x.y`` when that is a module."""
    found = []
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        source = ".".join(("cobotsafety", *(parts[:-1] if parts[-1] == "__init__" else parts)))
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("cobotsafety"):
                names = [f"{node.module}.{alias.name}" if _is_module(f"{node.module}.{alias.name}") else node.module
                         for alias in node.names]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names if alias.name.startswith("cobotsafety.")]
            found += [(source, name, str(path.relative_to(PACKAGE))) for name in names if name != source]
    return found


def _is_module(name: str) -> bool:
    relative = Path(*name.split(".")[1:])
    return (PACKAGE / relative).with_suffix(".py").is_file() or (PACKAGE / relative / "__init__.py").is_file()


def package_graph() -> nx.DiGraph:
    graph = nx.DiGraph()
    for source, target, where in imports():
        a, b = (source.split(".") + [""])[1], (target.split(".") + [""])[1]
        if a != b:
            graph.add_edge(a, b, where=where)
    return graph


def test_no_module_imports_one_that_imports_it_back():
    """Module by module (a package may use another's leaf helper, e.g. ``cli.arguments``, while
    that package's commands import it: no module is on a cycle)."""
    graph = nx.DiGraph()
    for source, target, where in imports():
        graph.add_edge(source, target, where=where)
    cycles = list(nx.simple_cycles(graph))
    assert cycles == [], [[(a, graph.edges[a, b]["where"]) for a, b in zip(c, c[1:] + c[:1])] for c in cycles]


@pytest.mark.parametrize("core", sorted(CORE))
def test_the_core_never_imports_what_is_built_on_it(core):
    graph = package_graph()
    above = set(graph.successors(core)) & UPPER if core in graph else set()
    assert not above, {t: graph.edges[core, t]["where"] for t in above}
