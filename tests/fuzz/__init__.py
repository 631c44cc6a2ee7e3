"""Fuzzers of transgen's input handling (run a small seed in the suite, the long run in
``benchmarks/fuzz_mech.py``)."""
