"""Benchmark of the mode-generator pipeline (issue: < 0.5 s numeric for a 10-speed class
transmission, < 10 s symbolic for the HT-740). Prints figures; asserts nothing.

    python benchmarks/bench_pipeline.py
"""
from __future__ import annotations

import time

from transgen import bundled_mechanisms, load_mechanism
from transgen.graph import build_graph, link_nodes
from transgen.kinematics import combinations
from transgen.modes import mode_models, valid_coordinate_sets
from transgen.statespace import state_space


def _timed(label, func):
    t = time.perf_counter()
    out = func()
    dt = time.perf_counter() - t
    print(f"  {label:<44} {dt * 1000:9.1f} ms")
    return out, dt


def numeric_pipeline(name: str) -> float:
    path = bundled_mechanisms()[name]
    print(f"{name}: numeric pipeline")
    total = 0.0
    mech, dt = _timed("parse", lambda: load_mechanism(path))
    total += dt
    combos, dt = _timed(f"all 2^{len(mech.elements)} combinations (rank tests)", lambda: combinations(mech))
    total += dt
    models, dt = _timed("default modes, E/F, G, DOF", lambda: mode_models(mech))
    total += dt
    links = link_nodes(build_graph(mech))
    sets, dt = _timed("enumerate valid coordinate sets", lambda: valid_coordinate_sets(models, links))
    total += dt
    _, dt = _timed("state-space matrices", lambda: state_space(mech, models=models))
    total += dt
    all_models, dt = _timed(f"all {len(combos)} modes: E/F, G, DOF", lambda: mode_models(mech, "all"))
    print(f"  total (default modes) {total * 1000:.1f} ms; {len(sets)} valid coordinate sets; "
          f"{sum(m.equations is not None for m in all_models)} of {len(all_models)} combinations solvable")
    return total


def symbolic_ht740(symbols: str = "all") -> float:
    mech = load_mechanism("ht740")
    print(f"ht740: symbolic matrices (symbols: {symbols})")
    t = time.perf_counter()
    for model in mode_models(mech):
        t0 = time.perf_counter()
        from transgen.modes import mode_model

        mode_model(mech, model.mode, symbolic=symbols)
        print(f"  {model.name} ({' '.join(model.locked)}, {model.dof} DOF) {time.perf_counter() - t0:8.2f} s")
    total = time.perf_counter() - t
    print(f"  total {total:.2f} s (goal < 10 s)")
    return total


if __name__ == "__main__":
    largest = max(bundled_mechanisms(), key=lambda n: len(load_mechanism(bundled_mechanisms()[n]).elements)
                  + len(load_mechanism(bundled_mechanisms()[n]).gears))
    t = numeric_pipeline(largest)
    print(f"  goal < 0.5 s for the largest bundled transmission: {'met' if t < 0.5 else 'NOT met'}\n")
    numeric_pipeline("ht740")
    print()
    symbolic_ht740("inertias")
    print()
    symbolic_ht740("all")  # the two-DOF modes by the structured null-space route
