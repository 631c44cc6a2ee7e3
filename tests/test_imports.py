"""The project's import graph has no cycle, and the simulator's packages import one way.

The graph is built from the source (every ``import`` and ``from ... import`` statement, also those
inside functions: a lazy import that closes a cycle is still a cycle; and the entries of a
package's lazy-import table ``_WHERE``), over the modules of ``transgen`` and ``transgen.sim`` (the
folders ``transgen/`` and ``sim/``, installed as ``transgen.sim``).
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
        if path.name == "__init__.py":
            for target in _lazy_table(path, name):
                if target in modules:
                    graph.add_edge(name, target)
    return graph


def _lazy_table(path: Path, package: str) -> list[str]:
    """The submodules a package's ``_WHERE = {name: submodule}`` (transgen.lazy) loads names from."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "_WHERE" for t in node.targets) \
                and isinstance(node.value, ast.Dict):
            found += [f"{package}.{v.value}" for v in node.value.values
                      if isinstance(v, ast.Constant) and isinstance(v.value, str)]
    return found


# The simulator's packages from the bottom up: a module may import its own package and those below
# it, never one above. ``transgen.sim`` is the package's own ``__init__`` (its lazy API table).
SIM_LAYERS = ["transgen.sim" + (f".{name}" if name else "") for name in (
    "core",      # the shared vocabulary: compiled-or-Python scalars, tables, signals, Result
    "engine",    # the turbodiesel, the turbocharger and the torque converter
    "model",     # the transmission at run time, components, driveline, powertrain assembly
    "control",   # shift schedules, the driver, drive cycles
    "solve",     # integration, ODE solvers, events, monitor, the two clutch models, simulate()
    "analysis",  # shift quality, comfort, reports, plots, result files
    "scenario",  # scenario files: reading, schema, keys, overrides, bundled files
    "derive",    # scenarios derived from a mechanism (scenario new) and their acceptance
    "",          # transgen.sim itself: the package's lazy API
    "cli",       # the simulator's commands
    "study",     # sweeps and the shift calibration's optimizer, on top of all of it
    "data",      # the script that regenerates the shipped maps
)]


def sim_layer(module: str) -> str:
    """The entry of :data:`SIM_LAYERS` a module of ``transgen.sim`` belongs to."""
    parts = module.split(".")
    if len(parts) == 2:
        return module
    layer = ".".join(parts[:3])
    assert layer in SIM_LAYERS, f"{module}: its package {layer} is not placed in SIM_LAYERS"
    return layer


def test_every_simulator_module_sits_in_a_declared_package():
    graph = import_graph()
    sim = [n for n in graph if n == "transgen.sim" or n.startswith("transgen.sim.")]
    layers = {sim_layer(n) for n in sim}
    assert {"transgen.sim.core", "transgen.sim.solve", "transgen.sim.derive"} <= layers and len(layers) == len(SIM_LAYERS)
    assert not [n for n in sim if n.count(".") == 2 and n not in SIM_LAYERS and not n.startswith("transgen.sim.cli")]


def upward(edges) -> list[str]:
    """The imports ``a -> b`` between modules of transgen.sim whose target sits in a package above."""
    rank = {layer: k for k, layer in enumerate(SIM_LAYERS)}
    return sorted(f"{a} -> {b}" for a, b in edges if a.startswith("transgen.sim") and b.startswith("transgen.sim")
                  and rank[sim_layer(a)] < rank[sim_layer(b)])


def test_no_import_goes_back_up_between_the_simulators_packages():
    """The graph by package has no arrow back up (a package importing one above it)."""
    graph = import_graph()
    found = upward(graph.edges)
    assert not found, "imports that go back up: " + "; ".join(found)
    by_package = nx.DiGraph((sim_layer(a), sim_layer(b)) for a, b in graph.edges
                            if a.startswith("transgen.sim") and b.startswith("transgen.sim") and sim_layer(a) != sim_layer(b))
    assert nx.is_directed_acyclic_graph(by_package) and by_package.number_of_edges() > 10


def test_the_upward_check_can_fail():
    """A made-up arrow from the models to the analysis is one going back up; the reverse is not."""
    a, b = "transgen.sim.model.components", "transgen.sim.analysis.report"
    assert upward([(a, b)]) == [f"{a} -> {b}"] and upward([(b, a)]) == []


def test_the_core_of_transgen_does_not_import_the_simulator():
    """Mechanism, modes, matrices and drawings know nothing of the simulator; only the command
    lines, the FMU export and the synthesis (which runs sweeps) import it."""
    graph = import_graph()
    allowed = ("transgen.cli", "transgen.fmu", "transgen.synthesis", "transgen.sim")
    importers = {a for a, b in graph.edges if b.startswith("transgen.sim") and not a.startswith(allowed)}
    assert not importers, sorted(importers)


def test_the_graph_sees_the_project():
    graph = import_graph()
    assert "transgen.sim.solve.switching" in graph and any(n.startswith("transgen.drawing") for n in graph)
    assert graph.has_edge("transgen.sim.solve.switching", "transgen.sim.solve.integration")
    assert graph.has_edge("transgen.sim.solve.compliant", "transgen.sim.solve.integration")
    assert graph.has_edge("transgen.sim", "transgen.sim.scenario.load")  # a lazy-import table
    assert graph.number_of_edges() > 50


def test_no_import_cycle():
    cycles = list(nx.simple_cycles(import_graph()))
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c + c[:1]) for c in cycles[:10])


def test_the_clutch_models_are_siblings():
    graph = import_graph()
    for a, b in (("switching", "compliant"), ("compliant", "switching")):
        assert not nx.has_path(graph, f"transgen.sim.solve.{a}", f"transgen.sim.solve.{b}")
    assert not nx.has_path(graph, "transgen.sim.solve.integration", "transgen.sim.solve.simulate")


def test_the_study_package_sits_on_top_of_the_simulator():
    """transgen.sim.study (sweeps) uses the simulator; nothing of the simulator or the core imports
    it (only the command line wires its command in, and ``synthesize topology`` its executors)."""
    graph = import_graph()
    study = {n for n in graph if n == "transgen.sim.study" or n.startswith("transgen.sim.study.")}
    assert "transgen.sim.study.runner" in study
    importers = {a for a, b in graph.edges if b in study and a not in study}
    assert importers <= {"transgen.cli", "transgen.synthesis.topology_cli"}, sorted(importers)
    assert graph.has_edge("transgen.sim.study.task", "transgen.sim")
