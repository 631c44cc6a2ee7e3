"""Bad ``.mech`` input and command-line behaviour found by fuzzing (issue 10, section 3): each
reproducer is refused with a located, bounded message and exit 2, or handled as documented."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import warnings

import pytest

from transgen import MechError, bundled_mechanisms, parse_mechanism
from transgen.cli import EXIT_BROKEN_PIPE, main
from transgen.errors import MAX_SHOWN, CombinationLimitWarning, Diagnostic
from transgen.kinematics import MAX_COMBINATIONS, engaged_combinations
from transgen.language import INERTIA, MAX_NUMBER_LENGTH, RATIO, read_number
from transgen.modes import select_modes

MECHS = bundled_mechanisms()
SIMPLE2 = MECHS["simple2"].read_text(encoding="utf-8")
COMMANDS = [["check"], ["ratios"], ["modes"], ["matrices"], ["std"], ["graph", "-o", "g.dot"]]


def _diagnostics(text: str) -> list[Diagnostic]:
    with pytest.raises(MechError) as info:
        parse_mechanism(text, "bad.mech")
    return info.value.diagnostics


def _line_col(text: str, needle: str) -> tuple[int, int]:
    for number, line in enumerate(text.split("\n"), start=1):
        if needle in line:
            return number, line.index(needle) + 1
    raise AssertionError(needle)


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
def test_zero_ratio_with_huge_exponent_is_a_located_error_of_every_command(command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    text = SIMPLE2.replace("ratio=6.667", "ratio=0e400")
    bad = tmp_path / "bad.mech"
    bad.write_text(text, encoding="utf-8")
    assert main([command[0], str(bad), *command[1:]]) == 2
    line, col = _line_col(text, "0e400")
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:{line}:{col}: error: ratio must be between 1e-06 and 1e+06 in magnitude")
    assert not (tmp_path / "g.dot").exists()


@pytest.mark.parametrize("value, words", [
    ("5e-324", "below the smallest normal double"),
    ("-5e-324", "below the smallest normal double"),
    ("1e-400", "would read as 0"),
    ("1e-16", "must be 0 or between 1e-15 and 1e+15 kg*m^2"),
    ("2e15", "must be 0 or between 1e-15 and 1e+15 kg*m^2"),
    ("1e400", "must be a finite number"),
    ("1e" + "9" * 4401, f"at most {MAX_NUMBER_LENGTH}"),
], ids=lambda x: x[:20])
def test_inertias_outside_the_physical_range_are_located(value, words):
    text = SIMPLE2.replace("link Li J=2.9", f"link Li J={value}")
    (d,) = _diagnostics(text)
    line, col = _line_col(text, f"J={value}")
    assert (d.line, d.column) == (line, col + 2)
    assert d.message.startswith("J ") and words in d.message
    assert len(d.format()) < 700  # the 4401-digit exponent is not echoed


@pytest.mark.parametrize("text, expected", [("0", 0.0), ("-0", 0.0), ("0e400", 0.0), ("1e-15", 1e-15), ("2.9", 2.9), ("1e15", 1e15)])
def test_admissible_inertias(text, expected):
    value = read_number(text, "J", INERTIA)
    assert value == expected and not (isinstance(value, float) and str(value) == "-0.0")


@pytest.mark.parametrize("text", ["0", "0e400", "1e-7", "-2e6", "1e400"])
def test_gear_ratio_must_be_a_sensible_nonzero_number(text):
    assert isinstance(read_number(text, "ratio", RATIO), str)
    assert read_number("-6.04", "ratio", RATIO) == -6.04


@pytest.mark.parametrize("word", ["nan", "NaN", "inf", "Infinity"])
def test_nan_and_infinity_are_refused(word):
    (d,) = _diagnostics(SIMPLE2.replace("static=1000", f"static={word}"))
    assert d.message == f"static must be a number, not '{word}' (NaN and infinity are refused)"


def test_tooth_counts_have_an_upper_bound():
    text = "link A J=1\nlink B J=1\ngears G A B N1=20 N2=1e6\ninput A\noutput B\n"
    (d,) = _diagnostics(text)
    assert d.message == "N2 is a tooth count: at most 100000, not 1e6"


def test_a_line_with_ten_thousand_parameters_gives_a_bounded_message():
    text = SIMPLE2.replace("link La J=0", "link La J=0 " + " ".join(f"x{i}=1" for i in range(10_000)))
    with pytest.raises(MechError) as info:
        parse_mechanism(text, "bad.mech")
    assert len(info.value.diagnostics) == 10_000
    message = str(info.value)
    assert len(message) < 20 * 1000
    assert message.endswith(f"... and {10_000 - MAX_SHOWN} more errors")


def test_diagnostic_shows_a_window_of_a_long_line():
    line = "link A J=1 " + "y" * 5000 + " J=@"
    d = Diagnostic("a.mech", 1, len(line), "m" * 5000, line)
    head, source, caret = d.format().split("\n")
    assert len(head) < 500 and head.endswith("...")
    assert len(source) < 120 and source.lstrip().startswith("...")
    assert source[caret.index("^")] == "@"


def test_too_many_syntax_errors_stop_after_a_hundred():
    with pytest.raises(MechError) as info:
        parse_mechanism("@\n" * 10_000)
    assert len(info.value.diagnostics) == 101 and "too many syntax errors" in info.value.diagnostics[-1].message


def _chain(n_elements: int) -> str:
    lines = [f"link L{i} J=1" for i in range(n_elements + 1)]
    lines += [f"clutch C{i} L{i} L{i + 1} static=10 dynamic=8" for i in range(n_elements)]
    return "\n".join(lines + ["input L0", f"output L{n_elements}"]) + "\n"


def test_combinations_are_capped_with_a_warning():
    names = [f"C{i}" for i in range(14)]
    with pytest.warns(CombinationLimitWarning, match="14 shift elements give 16384 combinations; only the 470"):
        combos = engaged_combinations(names)
    assert len(combos) == 470 <= MAX_COMBINATIONS and max(map(len, combos)) == 3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(engaged_combinations(names[:10])) == 1024


def test_modes_of_fourteen_clutches_without_gear_table_is_fast(tmp_path, capsys):
    path = tmp_path / "chain14.mech"
    path.write_text(_chain(14), encoding="utf-8")
    start = time.perf_counter()
    assert main(["modes", str(path)]) == 0
    assert time.perf_counter() - start < 20  # was 93 s
    out, err = capsys.readouterr()
    assert "warning: 14 shift elements give 16384 combinations" in err
    assert "static diagnosis over 470 of 16384 combinations (at most 3 engaged)" in out


@pytest.mark.parametrize("name", sorted(MECHS))
def test_matrices_of_every_combination_list_the_tie_ups_and_exit_0(name, capsys):
    assert main(["matrices", name, "--modes", "all"]) == 0
    out, err = capsys.readouterr()
    data = json.loads(out)
    n = len(select_modes(parse_mechanism(MECHS[name].read_text(encoding="utf-8")), "all"))
    assert len(data["modes"]) + len(data["skipped"]) == n
    for s in data["skipped"]:
        assert s["problem"] and f"  {s['name']} (" in err


def test_maps_bad_input_exits_2_with_a_located_message(tmp_path, capsys):
    bad = tmp_path / "map.toml"
    bad.write_text('format = "transgen-compressor-map"\nversion = 1\nname = [\n', encoding="utf-8")
    assert main(["maps", str(bad)]) == 2
    assert capsys.readouterr().err.startswith(f"{bad}:4:1: error: not valid TOML")
    bad.write_text('format = "transgen-compressor-map"\nversion = 1\n[reference]\ntemperature = 300\npressure = 1e5\n'
                   '[[speed_line]]\nspeed = 1\nmass_flow = ["a"]\n', encoding="utf-8")
    assert main(["maps", str(bad)]) == 2
    assert capsys.readouterr().err.startswith(f"{bad}:8:1: error: invalid map data:\n  speed_line[0].mass_flow")
    bad.write_text('format = 3\n', encoding="utf-8")
    assert main(["maps", str(bad)]) == 2
    assert capsys.readouterr().err.startswith(f"{bad}:1:1: error: 'format' must be one of")


@pytest.mark.parametrize("argv, suggestion", [
    (["ratios", "ht470"], "did you mean 'ht740'"),
    (["check", "zf8hp7.mech"], "did you mean 'zf8hp70'"),
    (["simulate", "ht740_orignal"], "did you mean 'ht740_original'"),
    (["maps", "we_compresor"], "did you mean 'we_compressor'"),
])
def test_misspelled_bundled_names_get_a_suggestion(argv, suggestion, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert suggestion in err and f"{argv[1]}:1:" in err


@pytest.mark.parametrize("argv", [["ratios", "zf8hp70"], ["matrices", "simple2"], ["list"]])
def test_writing_into_a_closed_pipe_exits_quietly(argv, tmp_path):
    """As ``transgen ratios zf8hp70 | head -1`` when head has gone: no message, exit 141."""
    read_end, write_end = os.pipe()
    os.close(read_end)  # every write now fails with EPIPE
    try:
        run = subprocess.run([sys.executable, "-m", "transgen", *argv], stdout=write_end, stderr=subprocess.PIPE,
                             env=dict(os.environ, MPLBACKEND="Agg"), timeout=120, cwd=tmp_path)  # not the checkout
    finally:
        os.close(write_end)
    assert run.stderr == b"" and run.returncode == EXIT_BROKEN_PIPE


def test_matrices_refuse_a_mechanism_in_which_no_combination_can_be_modelled(capsys):
    from transgen.errors import ModeError
    from transgen.statespace import state_space

    mech = parse_mechanism("link A J=1\nlink B J=1\nlink X J=0\nclutch K A B static=1 dynamic=1\ninput A\noutput B\n")
    with pytest.raises(ModeError, match="massless link"):
        state_space(mech, which="all")


def test_an_error_message_into_a_closed_pipe_keeps_the_exit_code(tmp_path):
    """``transgen ratios bad.mech 2>&1 | head -1``: the message cannot be written, the exit code is 2."""
    bad = tmp_path / "bad.mech"
    bad.write_text(SIMPLE2.replace("ratio=6.667", "ratio=0e400"), encoding="utf-8")
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        run = subprocess.run([sys.executable, "-m", "transgen", "ratios", str(bad)], stdout=write_end,
                             stderr=write_end, env=dict(os.environ, MPLBACKEND="Agg"), timeout=120, cwd=tmp_path)
    finally:
        os.close(write_end)
    assert run.returncode == 2
