"""Scenario files: bad input refused at load with ``FILE:LINE:COL: error:`` (issue 10, section 3),
the new signal kinds (pulses, square waves, periodic tables, jumps in tables) and the fuzzer."""
from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from transgen.errors import ScenarioError
from transgen.cli import main
from transgen.sim.scenario.load import load_scenario, output_signals, parse_scenario
from transgen.sim.core.signals import Constant, Periodic, Pulse, Ramp, Sine, Spliced, Step, Sum, Table
from transgen.sim.solve.simulate import Powertrain, SolverOptions, simulate
from transgen.sim.scenario.tomlpos import key_positions

sys.path.insert(0, str(Path(__file__).parent))
from fuzz.fuzz_scenario import dumps, fuzz_scenarios  # noqa: E402
from test_sim_simulate import BASE as SIMPLE2  # noqa: E402

BASE = SIMPLE2.lstrip("\n") + "[driveline]\noutput_inertia = 100.0\nstiffness = 12000.0\ndamping = 200.0\n"


def _refused(text: str, path="s.toml") -> str:
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(text, path)
    return str(exc.value)


# ----------------------------------------------------------------------------- positions


def test_key_positions_cover_tables_inline_tables_arrays_and_arrays_of_tables():
    text = textwrap.dedent("""\
        a = 1 # comment with = and [
        [t.u]
        s = "x = [1]"
        v = { w = [0, 1,
          2], "q k" = 'z' }
        [[load]]
        torque = "T"
        [[load]]
        c0 = 1
        """)
    pos = key_positions(text)
    assert pos[("a",)] == (1, 1)
    assert pos[("t", "u")] == (2, 1) and pos[("t", "u", "s")] == (3, 1)
    assert pos[("t", "u", "v", "w")] == (4, 7) and pos[("t", "u", "v", "w", 2)] == (5, 3)
    assert pos[("t", "u", "v", "q k")] == (5, 7)
    assert pos[("load", 0, "torque")] == (7, 1) and pos[("load", 1, "c0")] == (9, 1)


# ----------------------------------------------------------------------------- refused at load


@pytest.mark.parametrize("old, new, where, words", [
    ("torque = 100.0", "torque = nan", "8:1", "'input.torque' is not a finite number"),
    ("torque = 100.0", 'torque = { type = "table", t = [0, 1], value = [0, inf] }', "8:52", "input.torque.value.1"),
    ("Li = 100.0", "Li = -inf", "6:12", "'initial.speeds.Li' is not a finite number"),
    ("t_end = 1.0", "t_end = 1e400", "3:1", "too large for a float"),
    ("stiffness = 12000.0", "stiffness = 1" + "0" * 400, "11:1", "'driveline.stiffness' is not a finite number"),
    ("speeds = { Li = 100.0 }", "speeds = 5", "6:1", "speeds must be a table"),
    ("speeds = { Li = 100.0 }", 'speeds = { Li = "fast" }', "6:12", "'Li' must be a finite number, not 'fast'"),
    ("torque = 100.0", "torque = [1, 2]", "8:1", "a signal is a finite number or a table"),
    ('gear = "1"', "gear = [1]", "5:1", "unknown gear [1]"),
    ('gear = "1"', "gear = true", "5:1", "unknown gear True"),
    ('mechanism = "simple2"', "mechanism = 5", "1:1", "'mechanism' must be a string"),
    ("[simulation]\nt_end = 1.0", "simulation = 3", "2:1", "[simulation] must be a table, not 3"),
    ('mechanism = "simple2"', 'load = [5]\nmechanism = "simple2"', "1:9", "each [[load]] is a table, not 5"),
    ("t_end = 1.0", 't_end = 1.0\nmethod = ["RK45"]', "4:1", "'method' must be a string"),
    ("t_end = 1.0", "t_end = 1.0\noutput_dt = 1e-12", "4:1", "output_dt = 1e-12 s gives 1e+12 steps"),
])
def test_bad_values_are_refused_where_they_are_written(old, new, where, words):
    assert old in BASE
    message = _refused(BASE.replace(old, new, 1))
    assert message.startswith(f"s.toml:{where}: error: "), message
    assert words in message
    assert len(message) < 3000


@pytest.mark.parametrize("extra, where, words", [
    ("[elements.C2]\napply = nan\n", "14:1", "'elements.C2.apply' is not a finite number"),
    ('[elements.C2]\napply = { type = "table", t = ["a", "b"], value = [1, 2] }\n', "14:32", "entry 1 is 'a'"),
    ('[elements.C2]\napply = { type = "table", t = [[0, 1]], value = [[1, 2]] }\n', "14:32", "entry 1 is [0, 1]"),
    ('[elements.C2]\napply = { type = "table", t = [0, 2, 1], value = [0, 1, 1] }\n', "14:38", "must not decrease"),
    ('[elements.C2]\napply = { type = "pulse", t0 = 0.1, width = 0.2, period = 0.1 }\n', "14:50",
     "period > width"),
    ('[elements.C2]\napply = { type = "square", period = 1e-9 }\n', "14:28", "breakpoints in the simulated"),
    ('[elements.C2]\napply = { type = "periodic", t = [0, 1], value = [0, 1], period = 0.5 }\n', "14:58",
     "shorter than the table's span"),
    ('[elements.C2]\napply = { type = "sine", amplitude = 1, frequncy = 2 }\n', "14:41", "did you mean 'frequency'"),
    ('[elements.C2]\nfriction = { slip = [5, 1], factor = [1, 1] }\n', "14:14", "increasing speeds"),
    ("[[load]]\ntorque = 5\n", "14:1", "'torque' must be a string"),
    ('[output]\nsignals = ["w_Lo", "T_ot"]\n', "14:20", "unknown output signal 'T_ot'; did you mean 'T_out'?"),
    ("[output]\nsignals = [[1]]\n", "14:1", "'signals' must be a list of names"),
    ('[shifts]\nevents = [{ t = 1.0, from = "1", to = "2" }]\n', "14:13", "outside the simulated interval [0, 1) s"),
    ('[shifts]\nevents = [{ t = 2.5, from = "1", to = "2" }]\n', "14:13", "outside the simulated interval"),
    ('[shifts]\nevents = [{ t = 0.5, from = "1", to = "7" }]\n', "14:34", "unknown gear '7'"),
    ('[shifts]\nevents = { t = 0.5 }\n', "14:1", "events must be a list"),
    ('[shifts]\ntemplate = 5\nevents = []\n', "14:1", "[shifts.template] must be a table, not 5"),
    ('[auto_shift]\norder = ["1", "2"]\nthrottle = [0, 1]\nupshift_rpm = [["a", 1]]\ndownshift_rpm = [[1, 1]]\n',
     "16:17", "row 1, entry 1 is 'a'"),
    ('[auto_shift]\norder = ["1", "2"]\nthrottle = [0, 1]\nupshift_rpm = 5\ndownshift_rpm = [[1, 1]]\n',
     "16:1", "upshift_rpm must be 1 rows of 2"),
])
def test_wrong_types_and_unknown_names_are_refused(extra, where, words):
    message = _refused(BASE + extra)
    assert message.startswith(f"s.toml:{where}: error: "), message
    assert words in message


def test_an_error_in_an_included_file_is_reported_in_that_file(tmp_path):
    vehicle = tmp_path / "shared" / "vehicle.toml"
    vehicle.parent.mkdir()
    vehicle.write_text("# a vehicle\n[driveline]\noutput_inertia = 100.0\nstiffness = nan\n", encoding="utf-8")
    main_file = tmp_path / "s.toml"
    main_file.write_text('include = ["shared/vehicle.toml"]\n' + BASE.split("[driveline]")[0], encoding="utf-8")
    message = _refused(main_file.read_text(), main_file)
    assert message.startswith(f"{vehicle}:4:1: error: 'driveline.stiffness' is not a finite number"), message
    # a wrong type, found only once the files are merged, is located in the file that gives the value
    vehicle.write_text("# a vehicle\n[driveline]\noutput_inertia = 100.0\nstiffness = \"stiff\"\n", encoding="utf-8")
    with pytest.raises(ScenarioError) as exc:
        load_scenario(main_file)
    assert str(exc.value).startswith(f"{vehicle}:4:1: error: 'stiffness' must be a finite number"), str(exc.value)
    # ... and a value the including file overrides is located there
    main_file.write_text('include = ["shared/vehicle.toml"]\n' + BASE.split("[driveline]")[0]
                         + '[driveline]\nstiffness = "soft"\n', encoding="utf-8")
    with pytest.raises(ScenarioError) as exc:
        load_scenario(main_file)
    assert str(exc.value).startswith(f"{main_file}:11:1: error: 'stiffness' must be"), str(exc.value)


def test_bad_includes_are_located_at_the_include(tmp_path):
    p = tmp_path / "s.toml"
    (tmp_path / "sub").mkdir()
    (tmp_path / "junk.toml").write_text("not [toml\n", encoding="utf-8")
    for include, where, words in (('["nowhere.toml"]', f"{p}:1:12", "included file 'nowhere.toml' not found"),
                                  ('["s.toml"]', f"{p}:1:12", "include cycle"),
                                  ('["./sub/../s.toml"]', f"{p}:1:12", "include cycle"),
                                  ("5", f"{p}:1:1", "include must be a file name or a list of file names"),
                                  ('[["a.toml"]]', f"{p}:1:1", "include must be a file name or a list"),
                                  ('"junk.toml"', f"{tmp_path / 'junk.toml'}:1:5", "TOML syntax")):
        p.write_text(f"include = {include}\n" + BASE, encoding="utf-8")
        with pytest.raises(ScenarioError) as exc:
            load_scenario(p)
        assert str(exc.value).startswith(where + ": error: ") and words in str(exc.value), str(exc.value)


def test_deep_nesting_and_misspelled_bundled_names():
    assert _refused("a = " + "[" * 3000 + "]" * 3000 + "\n").startswith("s.toml:1:1: error: arrays or tables nested too deeply")
    with pytest.raises(ScenarioError, match="did you mean 'ht740_improved'"):
        load_scenario("ht740_improvd")


def test_cli_refuses_nan_torque_with_exit_2_instead_of_hanging(tmp_path, capsys):
    p = tmp_path / "s.toml"
    p.write_text(BASE.replace("torque = 100.0", "torque = nan"), encoding="utf-8")
    out = tmp_path / "out.csv"
    assert main(["simulate", str(p), "--quiet", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{p}:8:1: error:" in err and "Traceback" not in err and not out.exists()


def test_output_signals_are_the_columns_of_a_run():
    s = parse_scenario(BASE.replace("t_end = 1.0", "t_end = 0.05"), "s.toml")
    r = s.run()
    assert set(output_signals(s.powertrain)) == set(r.signals)


def test_scenario_from_text_equals_scenario_from_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(BASE, encoding="utf-8")
    a, b = load_scenario(p), parse_scenario(BASE, p)
    assert a.options == b.options and np.allclose(a.powertrain.initial_speeds, b.powertrain.initial_speeds)


# ----------------------------------------------------------------------------- signals


def test_a_table_with_equal_consecutive_times_jumps():
    t = Table((0.0, 1.0, 1.0, 2.0), (0.0, 0.0, 1.0, 1.0))
    assert t.value(0.999999) == 0.0 and t.value(1.0) == 1.0 and t.value(1.5) == 1.0  # right-continuous
    assert t.breakpoints() == (0.0, 1.0, 2.0)
    ts = np.array([-1.0, 0.5, 1.0 - 1e-12, 1.0, 1.5, 3.0])
    assert list(t.sample(ts)) == [t.value(x) for x in ts]
    start = Table((0.0, 0.0, 1.0), (0.0, 1.0, 1.0))  # a jump at the first time
    assert start.value(-1e-9) == 0.0 and start.value(0.0) == 1.0
    three = Table((0.0, 1.0, 1.0, 1.0, 2.0), (0.0, 0.0, 5.0, 1.0, 1.0))  # the middle value is never taken
    assert three.times == (0.0, 1.0, 1.0, 2.0) and three.value(1.0) == 1.0
    with pytest.raises(ValueError):
        Table((0.0, 2.0, 1.0), (0.0, 1.0, 1.0))


def test_pulses_and_square_waves():
    single = Pulse(0.5, 0.25, low=0.1, high=0.9)
    assert [single.value(x) for x in (0.0, 0.5, 0.7, 0.75, 2.0)] == [0.1, 0.9, 0.9, 0.1, 0.1]
    assert single.breakpoints() == (0.5, 0.75)
    train = Pulse(1.0, 0.02, period=0.1)
    assert train.value(0.99) == 0.0 and train.value(1.0) == 1.0 and train.value(1.019) == 1.0
    assert train.value(1.02) == 0.0 and train.value(1.1) == 1.0 and train.value(1.0 + 70 * 0.1) == 1.0
    points = train.breakpoints(0.0, 1.25)
    assert np.allclose(points, [1.0, 1.02, 1.1, 1.12, 1.2, 1.22])
    for b in train.breakpoints(1.0, 50.0)[::2]:  # every rising edge is high at its own time
        assert train.value(b) == 1.0, b
    with pytest.raises(ValueError, match="finite window"):
        train.breakpoints()


def test_a_periodic_table_repeats_with_its_jumps_and_kinks():
    base = Table((0.0, 0.1, 0.1, 0.3), (0.0, 0.5, 1.0, 1.0))
    p = Periodic(base, 0.4)  # holds 1.0 from 0.3 to 0.4, then drops to 0 (a jump at every period start)
    for k in (0, 1, 7, 250):
        t0 = 0.4 * k
        assert p.value(t0) == pytest.approx(0.0, abs=1e-9) and p.value(t0 + 0.05) == pytest.approx(0.25)
        assert p.value(t0 + 0.1) == pytest.approx(1.0) and p.value(t0 + 0.35) == 1.0
    assert p.value(-0.35) == pytest.approx(0.25)  # periodic before the table's first time too
    assert np.allclose(p.breakpoints(0.0, 0.85), [0.0, 0.1, 0.3, 0.4, 0.5, 0.7, 0.8])
    points = p.breakpoints(0.0, 100.0)  # right-continuous at every jump, despite round-off:
    values = [p.value(b) for b in points]  # 0 at the period starts, 1 after the jump at 0.1 and at the kink
    assert set(values) == {0.0, 1.0} and values.count(0.0) == 251 and len(points) == 3 * 250 + 1
    with pytest.raises(ValueError):
        p.breakpoints(0.0)
    with pytest.raises(ValueError):
        Periodic(base, 0.2)


def test_signal_upper_bounds_hold_for_the_new_kinds():
    signals = [Table((0, 1, 1, 2), (0, 0, 1, 0.5)), Pulse(0.5, 0.3, 0.2, -0.4), Pulse(0.1, 0.05, period=0.3),
               Periodic(Table((0, 0.2, 0.2, 0.5), (0, 1, -1, 0)), 0.7), Sum((Pulse(1.0, 0.5), Ramp(0, 2, 0, 1))),
               Spliced(1.5, Pulse(0.0, 0.1, period=0.25), Constant(0.1)), Sine(0.2, 0.5, 2.0), Step(1.0, 0.0, 0.5)]
    rng = np.random.default_rng(1)
    for s in signals:
        for _ in range(200):
            a, b = np.sort(rng.uniform(-1.0, 4.0, 2))
            grid = np.concatenate([np.linspace(a, b, 400), [x for x in s.breakpoints(a, b)]])
            assert max(s.value(t) for t in grid) <= s.upper_bound(a, b) + 1e-12, (s, a, b)
    assert Pulse(1.0, 0.5).upper_bound(0.0, 0.9) == 0.0 and Pulse(1.0, 0.5).upper_bound(0.0, 1.0) == 1.0
    assert Pulse(0.0, 1e-6, high=-1.0, period=1e-3).upper_bound(0.0, 1e9) == 0.0  # no enumeration of edges


def test_sums_and_splices_pass_the_window_on():
    s = Spliced(1.0, Pulse(0.0, 0.1, period=0.5), Periodic(Table((0.0, 0.2), (0.0, 1.0)), 0.3))
    assert np.allclose(s.breakpoints(0.0, 1.5), [0.0, 0.1, 0.5, 0.6, 1.0, 1.1, 1.2, 1.4, 1.5])
    assert Sum((Step(0.5, 0, 1), Pulse(0.2, 0.1, period=1.0))).breakpoints(0.0, 1.3) == pytest.approx((0.2, 0.3, 0.5, 1.2, 1.3))


# ----------------------------------------------------------------------------- simulated


TWO = """\
mechanism = "simple2"
[simulation]
t_end = 0.6
[initial]
gear = "1"
speeds = { Li = 100.0 }
[input]
torque = 400.0
[driveline]
output_inertia = 100.0
stiffness = 12000.0
damping = 200.0
"""


def _locks(result):
    return [(e.kind, e.elements, round(e.t, 6)) for e in result.events if e.kind != "start"]


def test_a_table_jump_simulates_as_the_step_it_is():
    jump = parse_scenario(TWO + '[elements.C2]\napply = { type = "table", t = [0.0, 0.2, 0.2, 1.0], '
                                'value = [0.0, 0.0, 1.0, 1.0] }\n', "jump.toml").run()
    step = parse_scenario(TWO + '[elements.C2]\napply = { type = "step", t = 0.2, before = 0.0, after = 1.0 }\n',
                          "step.toml").run()
    assert jump.success and step.success
    assert _locks(jump) == _locks(step) and _locks(jump)
    np.testing.assert_allclose(jump["w_Li"], step["w_Li"], rtol=1e-9, atol=1e-9)


def test_a_square_wave_apply_is_a_pulse_train_in_the_run():
    square = TWO + '[elements.C2]\napply = { type = "square", period = 0.2, duty = 0.25, t0 = 0.1, high = 0.3 }\n'
    table = (TWO + '[elements.C2]\napply = { type = "table", t = [0.1, 0.1, 0.15, 0.15, 0.3, 0.3, 0.35, 0.35, 0.5, 0.5, '
             '0.55, 0.55], value = [0, 0.3, 0.3, 0, 0, 0.3, 0.3, 0, 0, 0.3, 0.3, 0] }\n')
    a = parse_scenario(square, "square.toml").run()
    b = parse_scenario(table, "table.toml").run()
    assert a.success and b.success and _locks(a) == _locks(b)
    np.testing.assert_allclose(a["apply_C2"], b["apply_C2"])
    np.testing.assert_allclose(a["w_Li"], b["w_Li"], rtol=1e-9, atol=1e-9)


def test_the_energy_residual_is_relative_to_the_energies_of_the_run():
    """No work goes in (two spinning inertias, no input torque): the relative residual is a
    fraction of the energies that do move, not of the zero input work."""
    from transgen.language import parse_mechanism
    from transgen.sim.model.transmission import Transmission

    mech = parse_mechanism('transmission "pair"\nlink A J=1.0\nlink B J=1.0\nclutch C A B static=10 dynamic=10\n'
                           "input A\noutput B\n", "pair.mech")
    tr = Transmission(mech, {"C": {"apply": Constant(1.0)}})
    r = simulate(Powertrain(tr, [], np.array([10.0, 0.0])), SolverOptions(t_end=2.0))
    assert r.success and r.energy["work_in"] == 0.0 and r.energy["dissipated"] == pytest.approx(25.0, rel=1e-6)
    assert r.energy["relative_residual"] < 1e-6


# ----------------------------------------------------------------------------- fuzz


def test_the_toml_writer_of_the_fuzzer_reads_back():
    import tomllib

    data = {"a": 1, "b": [1.5, "x"], "c": {"d": {"e": [{"f": True}]}, "g h": -2.0}}
    assert tomllib.loads(dumps(data)) == data


def test_scenario_fuzz_small_seed():
    report = fuzz_scenarios(seed=11, count=60)
    assert not report.failures, report.text()
    assert report.outcomes.get("refused", 0) > 10 and report.outcomes.get("completed", 0) > 5, report.text()
