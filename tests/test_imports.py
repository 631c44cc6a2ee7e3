"""The project's import graph has no cycle.

The graph is built from the source (every ``import`` and ``from ... import`` statement, also those
inside functions: a lazy import that closes a cycle is still a cycle), over the modules of
``transgen`` and ``transgen.sim`` (the folders ``transgen/`` and ``sim/``, installed as
``transgen.sim``).
"""
from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"transgen": ROOT / "transgen", "transgen.sim": ROOT / "sim"}


def project_modules() -> dict[str, Path]:
    """Dotted module name -> source file (a package is its ``__init__.py``)."""
    modules = {}
    for prefix, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join([prefix, *parts])] = path
    return modules


def import_graph() -> nx.DiGraph:
    modules = project_modules()
    graph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")
                    anchor = anchor[: len(anchor) - (node.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                # `from pkg import sub` imports the submodule when there is one
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            for target in targets:
                while target and target not in modules:  # `import a.b.c` of a non-module attribute path
                    target = target.rpartition(".")[0]
                if target and target != name:
                    graph.add_edge(name, target)
    return graph


def test_the_graph_sees_the_project():
    graph = import_graph()
    assert "transgen.sim.switching" in graph and any(n.startswith("transgen.drawing") for n in graph)
    assert graph.has_edge("transgen.sim.switching", "transgen.sim.integration")
    assert graph.has_edge("transgen.sim.compliant", "transgen.sim.integration")
    assert graph.number_of_edges() > 50


def test_no_import_cycle():
    cycles = list(nx.simple_cycles(import_graph()))
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c + c[:1]) for c in cycles[:10])


def test_the_clutch_models_are_siblings():
    graph = import_graph()
    for a, b in (("switching", "compliant"), ("compliant", "switching")):
        assert not nx.has_path(graph, f"transgen.sim.{a}", f"transgen.sim.{b}")
    assert not nx.has_path(graph, "transgen.sim.integration", "transgen.sim.simulate")


def test_the_study_package_sits_on_top_of_the_simulator():
    """transgen.sim.study (sweeps) uses the simulator; nothing of the simulator or the core imports
    it (only the command line wires its command in, and ``synthesize topology`` its executors)."""
    graph = import_graph()
    study = {n for n in graph if n == "transgen.sim.study" or n.startswith("transgen.sim.study.")}
    assert "transgen.sim.study.runner" in study
    importers = {a for a, b in graph.edges if b in study and a not in study}
    assert importers <= {"transgen.cli", "transgen.synthesis.topology_cli"}, sorted(importers)
    assert graph.has_edge("transgen.sim.study.task", "transgen.sim")
