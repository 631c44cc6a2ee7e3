"""Corpus test of the bundled mechanism library (``mechanisms/*.mech``).

Every file must parse, and every gear with a published ratio must reproduce it to the precision
the source prints (``tests/data/published_ratios.json``, copied from the reference record of each
transmission; ratio = input speed / output speed, negative for reverse).
"""

import json
import re
from decimal import Decimal
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MECH_DIR = ROOT / "mechanisms"
PUBLISHED = json.loads(
    (Path(__file__).resolve().parent / "data" / "published_ratios.json").read_text(encoding="utf-8")
)["mechanisms"]

MECH_FILES = sorted(MECH_DIR.glob("*.mech"))
EPS = 1e-9  # float round-off allowance on top of the printed half-unit

_GEAR_LINE = re.compile(r"^\s*gear\s+(\w+)\s*=(.*)$")
_RATIO = re.compile(r"\bratio\s*=\s*(\S+)")


def _decimals(text):
    """Number of decimals printed in a ratio string ("1.0000" -> 4, "2.4" -> 1, "1" -> 0)."""
    return max(0, -Decimal(text).as_tuple().exponent)


def _declared_ratios(path):
    """``{gear: ratio string}`` of the ``gear ... ratio=X`` statements, read from the text."""
    out = {}
    for raw in path.read_text(encoding="utf-8").splitlines():
        line = raw.split("#", 1)[0]
        m = _GEAR_LINE.match(line)
        if m:
            r = _RATIO.search(m.group(2))
            out[m.group(1)] = r.group(1) if r else None
    return out


def _published_cases():
    return [
        pytest.param(name, gear, text, id=f"{name}:{gear}")
        for name, rec in sorted(PUBLISHED.items())
        for gear, text in rec["ratios"].items()
    ]


def test_library_is_not_empty():
    assert MECH_FILES, f"no .mech files in {MECH_DIR}"


def test_every_file_has_published_ratios_and_vice_versa():
    without = set(json.loads((Path(__file__).resolve().parent / "data" / "published_ratios.json")
                             .read_text(encoding="utf-8")).get("without_ratios", {}))
    on_disk = {p.name for p in MECH_FILES} - without
    assert on_disk == set(PUBLISHED), (
        f"only on disk: {sorted(on_disk - set(PUBLISHED))}, "
        f"only in published_ratios.json: {sorted(set(PUBLISHED) - on_disk)}"
    )


def test_published_entries_name_their_source():
    for name, rec in PUBLISHED.items():
        assert rec["ratios"], name
        assert rec["source"]["id"] and rec["source"]["url"], name
        for text in rec["ratios"].values():
            Decimal(text)  # a plain decimal string


@pytest.mark.parametrize("path", MECH_FILES, ids=lambda p: p.name)
def test_file_parses(path):
    from transgen import load_mechanism

    load_mechanism(path)


@pytest.mark.parametrize("name, gear, published", _published_cases())
def test_declared_ratio_equals_published_string(name, gear, published):
    declared = _declared_ratios(MECH_DIR / name)
    assert gear in declared, f"{name}: no 'gear {gear} = ...' statement"
    assert declared[gear] == published, (
        f"{name}: gear {gear} declares ratio={declared[gear]}, the source prints {published}"
    )


@pytest.fixture(scope="module")
def computed_ratios():
    from transgen import load_mechanism
    from transgen.kinematics import gear_ratios

    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = gear_ratios(load_mechanism(MECH_DIR / name))
        return cache[name]

    return get


@pytest.mark.parametrize("name, gear, published", _published_cases())
def test_computed_ratio_matches_published(computed_ratios, name, gear, published):
    ratios = computed_ratios(name)
    assert gear in ratios, f"{name}: gear {gear} missing from gear_ratios(): {sorted(ratios)}"
    value = ratios[gear]
    assert value is not None, f"{name}: gear {gear} has no unique ratio (not 1 DOF?)"
    tol = 0.5 * 10.0 ** -_decimals(published) + EPS
    assert abs(float(value) - float(published)) <= tol, (
        f"{name}: gear {gear} computes {float(value):.6f}, published {published} (tolerance {tol:.1e})"
    )
