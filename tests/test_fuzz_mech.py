"""A small seed of the ``.mech`` fuzzer (tests/fuzz/fuzz_mech.py) in the suite; the long run of
10,000 inputs and 200 command-line calls is ``benchmarks/fuzz_mech.py``."""
from __future__ import annotations

from fuzz.fuzz_mech import CLI_COMMANDS, fuzz_api, fuzz_cli


def test_api_fuzz_small_seed():
    report = fuzz_api(seed=20261201, count=200)
    assert not report.failures, "\n".join(map(str, report.failures))
    assert report.inputs == 200
    # the inputs reach every stage: parse errors, validation errors, and mechanisms that are modelled
    assert report.outcomes.get("modelled", 0) >= 20, report.summary()
    assert sum(v for k, v in report.outcomes.items() if "MechSyntaxError" in k) >= 20, report.summary()
    assert sum(v for k, v in report.outcomes.items() if "MechValidationError" in k) >= 20, report.summary()


def test_cli_fuzz_small_seed():
    report = fuzz_cli(seed=20261201, count=len(CLI_COMMANDS))
    assert not report.failures, "\n".join(map(str, report.failures))
    assert {k.split()[0] for k in report.outcomes} == set(CLI_COMMANDS)
