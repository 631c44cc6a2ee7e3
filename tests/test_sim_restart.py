"""Runs started from a saved state (:mod:`transgen.sim.solve.restart`): a run stopped at ``t`` and
restarted from its own state reproduces the continuous run after ``t`` within the solver
tolerance (events, speeds, output torque, energy integrals), also across an automatic schedule's
commands; a state refuses another powertrain and another start time."""
from __future__ import annotations

import pickle

import numpy as np
import pytest

from transgen.sim import load_scenario


def _compare(full, restarted, t_cut, tol):
    after = full.time > t_cut + 1e-9
    assert restarted.time[0] == pytest.approx(t_cut)
    for name in full.signals:
        if name.startswith("w_") or name in ("T_out", "E_in", "E_dissipated", "E_load"):
            y = np.interp(restarted.time[1:], full.time[after], full.signals[name][after])
            scale = max(1.0, float(np.max(np.abs(full.signals[name]))))
            assert np.max(np.abs(y - restarted.signals[name][1:])) <= tol * scale, name
    events = [(e.kind, e.elements) for e in full.events if e.t > t_cut + 1e-9]
    assert [(e.kind, e.elements) for e in restarted.events[1:]] == events
    times = [e.t for e in full.events if e.t > t_cut + 1e-9]
    assert [e.t for e in restarted.events[1:]] == pytest.approx(times, abs=1e-6)


@pytest.mark.parametrize("name, t_cut", [("simple2_upshift", 5.0), ("ht740_original", 7.4)])
def test_restart_reproduces_the_continuous_run(name, t_cut):
    full = load_scenario(name).run()
    first = load_scenario(name).run(t_end=t_cut)
    assert first.state.t == pytest.approx(t_cut)
    state = pickle.loads(pickle.dumps(first.state))  # plain data: what a worker gets
    restarted = load_scenario(name).run(start=state)
    assert restarted.success, restarted.message
    assert restarted.events[0].kind == "start" and restarted.events[0].detail == "from a saved state"
    _compare(full, restarted, t_cut, 1e-5)
    assert restarted.time[-1] == pytest.approx(full.time[-1])


def test_restart_across_an_automatic_schedule(tmp_path):
    from transgen.cli import main

    path = tmp_path / "launch.toml"
    assert main(["scenario", "new", "simple2", "-o", str(path)]) == 0
    full = load_scenario(path).run()
    commands = [e.t for e in full.events if e.kind == "command"]
    assert commands, "the launch shifts"
    t_cut = commands[0] + 0.05  # inside the first shift: the commanded applies are state
    restarted = load_scenario(path).run(start=load_scenario(path).run(t_end=t_cut).state)
    _compare(full, restarted, t_cut, 1e-4)


def test_state_refuses_another_powertrain_or_time():
    state = load_scenario("simple2_upshift").run(t_end=4.5).state
    other = load_scenario("ht740_original")
    with pytest.raises(ValueError, match="another powertrain"):
        other.run(start=state)
    same = load_scenario("simple2_upshift")
    from transgen.sim.solve.simulate import simulate

    with pytest.raises(ValueError, match="starts at its time"):
        simulate(same.powertrain, same.options, start=state)
