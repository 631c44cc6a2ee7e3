"""Fuzzers of transgen's input handling: `.mech` files (fuzz_mech.py) and scenarios (fuzz_scenario.py);
a small seed of each runs in the suite, the long runs in ``benchmarks/fuzz_mech.py`` and
``benchmarks/fuzz_scenario.py``."""
