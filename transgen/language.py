"""The ``.mech`` language: text -> :class:`~transgen.model.Mechanism`.

Parsing happens in three steps, each a plain function:

1. :func:`parse_tree` parses the text with the lark grammar ``grammars/mech.lark`` (LALR, with
   positions; lark's generated standalone parser, see :mod:`transgen.grammar_cache`). A syntax
   error in one line does not hide those in the others: since every statement is one line, the
   lines are re-parsed one by one to report them all.
2. :func:`_read_statements` turns the tree into statement records, checking each statement's
   parameters (known keys, types, ranges).
3. :func:`_resolve` builds the frozen :class:`Mechanism`, checking names (unknown names with the
   closest known one, duplicates) and the rules that need the whole file.

All problems are collected and raised together as one :class:`~transgen.errors.MechError`.
Parsing never evaluates code: numbers are read with :func:`float` / :func:`int`.

Size: about 630 lines, over the project's 500: the grammar's tree walk, the number checks and the
located diagnostics are one pass over the text; splitting them would hand positions across modules.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from .errors import Diagnostic, MechSyntaxError, MechValidationError
from .grammar_cache import parser_module
from .language_share import resolve_shares
from .library import package_folder
from .mech_format import ALTERNATIVE, format_mechanism
from .mech_numbers import (CAPACITY, DRAG, EFFICIENCY, INERTIA, MAX_NUMBER_LENGTH, RADIUS, RATIO, RATIO_TOL, SLIP_SPEED, TEETH,
                           _NOT_FINITE, Quantity, _suggest, read_number, shorten)
from .model import (
    HOUSING,
    ExternalTorque,
    Gear,
    GearPair,
    Link,
    Mechanism,
    ModeDecl,
    Planetary,
    STEPPED_MEMBERS,
    ShiftElement,
    Span,
    SteppedPlanetary,
)

if TYPE_CHECKING:
    from lark import Token, Tree
    from lark.exceptions import UnexpectedInput

__all__ = ["parse_mechanism", "load_mechanism", "parse_tree", "grammar_text", "format_mechanism"]

RESERVED = frozenset(
    {
        "transmission", "link", "planetary", "gears", "clutch", "brake", "oneway", "input",
        "output", "torque", "gear", "neutral", "mode", "coordinates", "none", HOUSING,
        ALTERNATIVE, "stepped", "dog", "share",
        "T_in", "T_out",  # the input and output torques of every mechanism
    }
)


def grammar_text() -> str:
    """The text of ``mech.lark`` as installed with the package."""
    return (package_folder("transgen.grammars") / "mech.lark").read_text(encoding="utf-8")


@functools.lru_cache(maxsize=1)
def _grammar() -> ModuleType:
    """The generated parser module of ``mech.lark`` (:func:`transgen.grammar_cache.parser_module`)
    with its parser as ``parser``: the tree and the exceptions are that module's classes."""
    module = parser_module(grammar_text(), parser="lalr", propagate_positions=True, maybe_placeholders=False)
    module.parser = module.Lark_StandAlone()
    return module


# ---------------------------------------------------------------------------------------------
# Step 1: syntax

_TERMINAL_NAMES = {
    "NAME": "a name",
    "GEARNAME": "a gear name",
    "MEMBER": "a planetary member SET.MEMBER (e.g. PG1.ring)",
    "NUMBER": "a number",
    "STRING": 'a quoted string ("...")',
    "EQUAL": "'='",
    "_NL": "end of line",
    "$END": "end of file",
}


def _describe_expected(expected: set[str]) -> str:
    words = []
    for name in sorted(expected):
        if name in _TERMINAL_NAMES:
            words.append(_TERMINAL_NAMES[name])
        elif name.isupper() and name.lower() in RESERVED:
            words.append(f"'{name.lower()}'")
        else:
            words.append(name)
    words = sorted(set(words))
    if len(words) > 6:
        return "a statement keyword (link, planetary, gears, clutch, brake, oneway, input, ...)"
    return ", ".join(words)


def _syntax_diagnostic(exc: UnexpectedInput, filename: str, lines: list[str], line_offset: int) -> Diagnostic:
    line = (exc.line if exc.line and exc.line > 0 else len(lines)) + line_offset
    column = exc.column if exc.column and exc.column > 0 else 1
    grammar = _grammar()
    if isinstance(exc, grammar.UnexpectedCharacters):
        char = lines[line - 1][column - 1] if 0 < line <= len(lines) and column <= len(lines[line - 1]) else "?"
        message = f"unexpected character {char!r}"
        if exc.allowed:
            message += f"; expected {_describe_expected(set(exc.allowed))}"
    elif isinstance(exc, grammar.UnexpectedToken):
        token = exc.token
        what = "end of line" if token.type == "_NL" else ("end of file" if token.type == "$END" else repr(str(token)))
        message = f"unexpected {what}; expected {_describe_expected(set(exc.expected))}"
    elif isinstance(exc, grammar.UnexpectedEOF):
        message = f"unexpected end of file; expected {_describe_expected(set(exc.expected))}"
    else:  # pragma: no cover - lark has no other kinds
        message = str(exc)
    source = lines[line - 1] if 0 < line <= len(lines) else ""
    return Diagnostic(filename, line, column, message, source)


def _lines(text: str) -> list[str]:
    """Lines as the grammar counts them: only ``\\n`` ends a line (``str.splitlines`` would also
    break at form feeds and other characters the grammar treats as blanks)."""
    return [line.rstrip("\r") for line in text.split("\n")]


MAX_SYNTAX_ERRORS = 100
"""Lines with syntax errors reported before :func:`parse_tree` stops looking."""


def parse_tree(text: str, filename: str = "<string>") -> Tree:
    """Parse ``.mech`` text into a lark tree (the ``Tree`` class of the generated parser, a copy of
    lark's: :mod:`transgen.grammar_cache`); raise :class:`MechSyntaxError` with every bad line."""
    if not text.endswith("\n"):
        text += "\n"
    grammar = _grammar()
    try:
        return grammar.parser.parse(text)
    except grammar.UnexpectedInput:
        pass
    lines = _lines(text)
    diagnostics = []
    for number, line in enumerate(lines, start=1):
        try:
            grammar.parser.parse(line + "\n")
        except grammar.UnexpectedInput as exc:
            diagnostics.append(_syntax_diagnostic(exc, filename, lines, number - 1))
            if len(diagnostics) == MAX_SYNTAX_ERRORS and number < len(lines):
                diagnostics.append(Diagnostic(filename, number + 1, 1, f"too many syntax errors: stopped after "
                                              f"{MAX_SYNTAX_ERRORS}", lines[number]))
                break
    if not diagnostics:  # pragma: no cover - a file is valid iff all its lines are
        diagnostics.append(Diagnostic(filename, 1, 1, "syntax error", lines[0] if lines else ""))
    raise MechSyntaxError(diagnostics)


# ---------------------------------------------------------------------------------------------
# Step 2: statements and their parameters


@dataclass(frozen=True)
class _Word:
    """A token with its position: a name or a value as written."""

    text: str
    span: Span


@dataclass
class _Statement:
    keyword: str
    span: Span
    words: list[_Word]
    params: dict[str, tuple[_Word, bool]] = field(default_factory=dict)  # key -> (value, is_number)
    elements: list[_Word] = field(default_factory=list)


def _word(token: Token) -> _Word:
    return _Word(str(token), Span(token.line, token.column))


class _Reporter:
    """Collects diagnostics for one file."""

    def __init__(self, filename: str, text: str):
        self.filename = filename
        self.text = text
        self.lines = _lines(text)
        self.diagnostics: list[Diagnostic] = []

    def suggest(self, name: str, known) -> str:
        """``_suggest``, for the first few errors only (each costs a scan of ``known``)."""
        return _suggest(name, known) if len(self.diagnostics) < 50 else ""

    def error(self, span: Span, message: str) -> None:
        line = max(span.line, 1)
        source = self.lines[line - 1] if line <= len(self.lines) else ""
        self.diagnostics.append(Diagnostic(self.filename, line, max(span.column, 1), message, source))


def _statements(tree: Tree, report: _Reporter) -> list[_Statement]:
    statements = []
    for node in tree.children:
        if isinstance(node, str):  # a token (lark's Token is a str), not a statement's tree
            continue
        stmt = _Statement(str(node.data), Span(node.meta.line, node.meta.column), [])
        for child in node.children:
            if isinstance(child, str):  # a Token
                stmt.words.append(_word(child))
            elif child.data == "param":
                key, value = child.children
                if str(key) in stmt.params:
                    report.error(_word(key).span, f"parameter '{key}' is given twice")
                stmt.params[str(key)] = (_word(value), value.type == "NUMBER")
                # keep the key position for messages about the key itself
                stmt.params[str(key) + "@key"] = (_word(key), False)
            elif child.data == "element":
                stmt.elements.append(_word(child.children[0]))
            elif child.data == "none":
                stmt.elements = []
        statements.append(stmt)
    return statements


# Allowed parameters per statement: key -> a Quantity, "name" (a link), or a tuple of allowed words.
_PARAMS: dict[str, dict[str, object]] = {
    "link": {"J": INERTIA},
    "planetary": {"sun": "name", "ring": "name", "carrier": "name", "Ns": TEETH, "Nr": TEETH, "pinions": ("1", "2"),
                  "eta0": EFFICIENCY},
    "gears": {"N1": TEETH, "N2": TEETH, "r1": RADIUS, "r2": RADIUS, "mesh": ("external", "internal"),
              "eta": EFFICIENCY},
    "clutch": {"static": CAPACITY, "dynamic": CAPACITY, "max_slip_rpm": SLIP_SPEED, "drag": DRAG},
    "brake": {"static": CAPACITY, "dynamic": CAPACITY, "type": ("plate", "band"), "max_slip_rpm": SLIP_SPEED,
              "drag": DRAG},
    "oneway": {"free": ("positive", "negative"), "max_slip_rpm": SLIP_SPEED},
    "dog": {"static": CAPACITY, "max_slip_rpm": SLIP_SPEED},
    "gear": {"ratio": RATIO, "tol": RATIO_TOL, "rounding": ("nearest", "truncated")},
    "stepped": {"carrier": "name", "sun1": "name", "sun2": "name", "ring1": "name", "ring2": "name",
                "Ns1": TEETH, "Ns2": TEETH, "Nr1": TEETH, "Nr2": TEETH, "Np1": TEETH, "Np2": TEETH,
                "eta0": EFFICIENCY},
}
_REQUIRED: dict[str, tuple[str, ...]] = {
    "link": ("J",),
    "planetary": ("sun", "ring", "carrier", "Ns", "Nr"),
    "clutch": ("static", "dynamic"),
    "brake": ("static", "dynamic"),
    "oneway": ("free",),
    "stepped": ("carrier",),
}
@dataclass(frozen=True)
class _UnknownTeeth:
    """A tooth count written ``?`` (``bounds`` None) or ``a..b``."""

    word: _Word
    bounds: tuple[int, int] | None


def _unknown_teeth(word: _Word, key: str, report: _Reporter) -> _UnknownTeeth | None:
    if word.text == "?":
        return _UnknownTeeth(word, None)
    low, high = (int(x) for x in word.text.split(".."))
    if not 1 <= low <= high <= TEETH.high:
        report.error(word.span, f"{key}={word.text}: a range of tooth counts a..b needs 1 <= a <= b <= {TEETH.high:g}")
        return None
    return _UnknownTeeth(word, (low, high))


def _check_params(stmt: _Statement, report: _Reporter) -> dict[str, object]:
    """Validate the key=value parameters of a statement; return their converted values."""
    allowed = _PARAMS.get(stmt.keyword, {})
    values: dict[str, object] = {}
    for key, (word, is_number) in stmt.params.items():
        if key.endswith("@key"):
            continue
        key_span = stmt.params[key + "@key"][0].span
        if key not in allowed:
            known = ", ".join(allowed) if allowed else "none"
            report.error(key_span, f"unknown parameter '{shorten(key)}' for '{stmt.keyword}'{_suggest(key, allowed)} (known: {known})")
            continue
        kind = allowed[key]
        if not is_number and (word.text == "?" or ".." in word.text):  # no name has these characters
            if kind is TEETH and stmt.keyword == "planetary":
                unknown = _unknown_teeth(word, key, report)
                if unknown is not None:
                    values[key] = unknown
            else:
                report.error(word.span, f"{key} cannot be unknown ('{shorten(word.text)}'): only the tooth counts "
                                        f"Ns, Nr of a planetary can be written ? or a..b")
            continue
        if isinstance(kind, tuple):
            if word.text not in kind:
                report.error(word.span, f"{key} must be one of {', '.join(kind)}, not '{shorten(word.text)}'")
                continue
            values[key] = word.text
        elif kind == "name":
            if is_number:
                report.error(word.span, f"{key} must name a link, not the number {shorten(word.text)}")
                continue
            values[key] = word
        else:
            if not is_number:
                if word.text.lower() in _NOT_FINITE:
                    report.error(word.span, f"{key} must be a number, not '{word.text}' (NaN and infinity are refused)")
                else:
                    report.error(word.span, f"{key} must be a number, not '{shorten(word.text)}'")
                continue
            number = read_number(word.text, key, kind)
            if isinstance(number, str):
                report.error(word.span, number)
                continue
            values[key] = word.text if stmt.keyword == "gear" and key in ("ratio", "tol") else number
    for key in _REQUIRED.get(stmt.keyword, ()):
        if key not in stmt.params:
            report.error(stmt.span, f"'{stmt.keyword}' needs {key}=...")
    return values


# ---------------------------------------------------------------------------------------------
# Step 3: names and whole-file rules


def _resolve(statements: list[_Statement], report: _Reporter, filename: str,
             unknown_teeth: bool = False) -> Mechanism | None:
    declared: dict[str, tuple[str, Span]] = {}  # link/planetary/gears/element/torque names

    def declare(word: _Word, what: str) -> bool:
        if word.text in RESERVED:
            report.error(word.span, f"'{word.text}' is a reserved word and cannot name a {what}")
            return False
        if word.text in declared:
            other_what, other = declared[word.text]
            report.error(word.span, f"duplicate name '{word.text}' (already a {other_what} at line {other.line})")
            return False
        declared[word.text] = (what, word.span)
        return True

    title = ""
    links: list[Link] = []
    planetaries, pairs, elements, loads, stepped = [], [], [], [], []
    gears: list[Gear] = []
    modes: list[ModeDecl] = []
    coordinates: list[_Word] = []
    inputs: list[_Word] = []
    outputs: list[_Word] = []
    link_refs: list[tuple[_Word, bool]] = []  # (reference, housing allowed)
    element_refs: list[_Word] = []
    share_statements: list[_Statement] = []

    for stmt in statements:
        params = _check_params(stmt, report)
        kw = stmt.keyword
        words = stmt.words
        if kw == "transmission":
            title = words[0].text[1:-1]
        elif kw == "link":
            if declare(words[0], "link") and "J" in params:
                links.append(Link(words[0].text, float(params["J"]), words[0].span))
        elif kw == "planetary":
            name = words[0]
            ok = declare(name, "planetary")
            members = [params.get(k) for k in ("sun", "ring", "carrier")]
            for m in members:
                if m is not None:
                    link_refs.append((m, True))
            present = [m for m in members if m is not None]
            texts = [m.text for m in present]
            for m in present:
                if texts.count(m.text) > 1 and m is present[texts.index(m.text)]:
                    report.error(m.span, f"planetary {name.text}: member '{m.text}' is used twice (sun, ring and carrier must be different links)")
            ns, nr = params.get("Ns"), params.get("Nr")
            bounds = {}
            for key in ("Ns", "Nr"):
                value = params.get(key)
                if isinstance(value, _UnknownTeeth):
                    bounds[key] = value.bounds
                    if not unknown_teeth:
                        report.error(value.word.span, f"planetary {name.text}: tooth count {key} is unknown "
                                                      f"({key}={value.word.text}); only 'transgen synthesize teeth' "
                                                      f"accepts unknown teeth: write a whole number")
                        ok = False
            ns, nr = (None if k in bounds else params.get(k) for k in ("Ns", "Nr"))
            if bounds and "Ns" in params and "Nr" in params and ok and None not in members and len(set(texts)) == 3:
                planetaries.append(Planetary(name.text, texts[0], texts[1], texts[2], ns, nr,
                                             int(params.get("pinions", "1")), name.span,
                                             bounds.get("Ns"), bounds.get("Nr"), eta0=params.get("eta0")))
            if ns is not None and nr is not None and nr <= ns:
                report.error(stmt.params["Nr"][0].span, f"planetary {name.text}: ring teeth Nr={nr} must exceed sun teeth Ns={ns}")
            if ok and None not in members and ns is not None and nr is not None and len(set(texts)) == 3 and nr > ns:
                planetaries.append(Planetary(name.text, texts[0], texts[1], texts[2], ns, nr, int(params.get("pinions", "1")), name.span,
                                             eta0=params.get("eta0")))
        elif kw == "stepped":
            item = _stepped(stmt, params, report, link_refs)
            if declare(words[0], "stepped planetary") and item is not None:
                stepped.append(item)
        elif kw == "gears":
            name, w1, w2 = words
            ok = declare(name, "gear pair")
            link_refs.extend([(w1, False), (w2, False)])
            if w1.text == w2.text:
                report.error(w2.span, f"gear pair {name.text} connects link '{w1.text}' to itself")
                ok = False
            by_teeth = "N1" in stmt.params or "N2" in stmt.params
            by_radius = "r1" in stmt.params or "r2" in stmt.params
            if by_teeth and by_radius:
                report.error(stmt.span, f"gear pair {name.text}: give tooth counts N1, N2 or radii r1, r2, not both")
                ok = False
            elif not by_teeth and not by_radius:
                report.error(stmt.span, f"gear pair {name.text} needs N1=... N2=... (tooth counts) or r1=... r2=... (radii in m)")
                ok = False
            keys = ("N1", "N2") if by_teeth else ("r1", "r2")
            for key in keys:
                if key not in stmt.params:
                    report.error(stmt.span, f"gear pair {name.text} needs {key}=...")
                    ok = False
            if ok and all(k in params for k in keys):
                pairs.append(GearPair(name.text, w1.text, w2.text, params[keys[0]], params[keys[1]],
                                      "teeth" if by_teeth else "radius", params.get("mesh", "external"), name.span,
                                      params.get("eta")))
        elif kw in ("clutch", "brake", "oneway", "dog"):
            name = words[0]
            ok = declare(name, {"oneway": "one-way clutch", "dog": "dog element"}.get(kw, kw))
            w1 = words[1]
            w2 = words[2] if len(words) > 2 else _Word(HOUSING, stmt.span)
            link_refs.append((w1, False))
            if kw != "brake":
                link_refs.append((w2, True))
            if w1.text == w2.text:
                report.error(w2.span, f"{kw} {name.text} connects '{w1.text}' to itself")
                ok = False
            if ok and all(k in params for k in _REQUIRED.get(kw, ())):
                if kw == "oneway":
                    static, dynamic = float("inf"), 0.0
                elif kw == "dog":
                    static, dynamic = float(params.get("static", float("inf"))), 0.0
                else:
                    static, dynamic = float(params["static"]), float(params["dynamic"])
                    if dynamic > static:
                        report.error(stmt.params["dynamic"][0].span,
                                     f"{kw} {name.text}: dynamic capacity {dynamic:g} N*m exceeds static capacity {static:g} N*m")
                elements.append(ShiftElement(name.text, kw, w1.text, w2.text, static, dynamic,
                                             params.get("free"), params.get("type"), name.span,
                                             params.get("max_slip_rpm"), params.get("drag")))
        elif kw == "input":
            inputs.append(words[0])
            link_refs.append((words[0], False))
        elif kw == "output":
            outputs.append(words[0])
            link_refs.append((words[0], False))
        elif kw == "torque":
            name, w = words
            if name.text.startswith("t_"):
                report.error(name.span, f"torque names starting with 't_' are reserved for the shift elements' "
                                        f"torques; rename '{name.text}'")
            elif declare(name, "torque"):
                loads.append(ExternalTorque(name.text, w.text, "load", name.span))
            link_refs.append((w, False))
        elif kw in ("gear", "neutral", "mode"):
            name = words[0]
            table = modes if kw == "mode" else gears
            flags = [w for w in stmt.elements if w.text == ALTERNATIVE]
            stmt.elements = [w for w in stmt.elements if w.text != ALTERNATIVE]
            for w in flags[(1 if kw == "gear" else 0):]:
                report.error(w.span, f"'{ALTERNATIVE}' marks a gear row ('gear NAME = ELEM ... {ALTERNATIVE}')"
                             if kw != "gear" else f"'{ALTERNATIVE}' is given twice")
            if any(g.name == name.text for g in table):
                report.error(name.span, f"duplicate {kw} name '{name.text}'")
            engaged = [w.text for w in stmt.elements]
            for w in stmt.elements:
                element_refs.append(w)
                if engaged.count(w.text) > 1 and w is stmt.elements[engaged.index(w.text)]:
                    report.error(w.span, f"{kw} {name.text} lists '{w.text}' twice")
            if kw == "mode":
                modes.append(ModeDecl(name.text, tuple(dict.fromkeys(engaged)), name.span))
            else:
                if not engaged:  # the grammar needs one word: only 'gear L = alternative' comes here
                    report.error(name.span, f"{kw} {name.text} engages no element")
                for key in ("tol", "rounding"):
                    if key in stmt.params and "ratio" not in stmt.params:
                        report.error(stmt.params[key + "@key"][0].span, f"{key}= says how ratio= is compared: give ratio=... too")
                if "tol" in stmt.params and "rounding" in stmt.params:
                    report.error(stmt.params["rounding@key"][0].span,
                                 "give tol= (an explicit tolerance) or rounding= (how the ratio was printed), not both")
                gears.append(Gear(name.text, tuple(dict.fromkeys(engaged)), kw, params.get("ratio"), name.span,
                                  params.get("tol"), params.get("rounding", "nearest"), bool(flags)))
        elif kw == "share":
            share_statements.append(stmt)
        elif kw == "coordinates":
            if coordinates:
                report.error(stmt.span, "coordinates are given twice")
            coordinates = list(words)
            link_refs.extend((w, False) for w in words)

    shares = resolve_shares(share_statements, declared, planetaries, report)
    link_names = {n for n, (what, _) in declared.items() if what == "link"}
    for ref, housing_ok in link_refs:
        if ref.text == HOUSING and housing_ok:
            continue
        if ref.text not in link_names:
            what = declared.get(ref.text, (None,))[0]
            if ref.text == HOUSING:
                report.error(ref.span, "the housing cannot be used here: name a link")
            elif what:
                report.error(ref.span, f"'{ref.text}' is a {what}, not a link")
            else:
                report.error(ref.span, f"unknown link '{shorten(ref.text)}'{report.suggest(ref.text, link_names)}")
    element_names = {n for n, (what, _) in declared.items() if what in ("clutch", "brake", "one-way clutch", "dog element")}
    for ref in element_refs:
        if ref.text not in element_names:
            report.error(ref.span, f"unknown shift element '{shorten(ref.text)}'{report.suggest(ref.text, element_names)}")
    for role, found in (("input", inputs), ("output", outputs)):
        if not found:
            last = max(1, len(report.lines) - (1 if report.lines and report.lines[-1] == "" else 0))
            report.error(Span(last, 1), f"missing '{role}' statement: name the {role} link, e.g. '{role} L1'")
        for extra in found[1:]:
            report.error(extra.span, f"the {role} is given twice")
    if inputs and outputs and inputs[0].text == outputs[0].text:
        report.error(outputs[0].span, f"input and output are the same link '{inputs[0].text}'")
    coord_texts = [w.text for w in coordinates]
    for w in coordinates:
        if coord_texts.count(w.text) > 1 and w is coordinates[coord_texts.index(w.text)]:
            report.error(w.span, f"coordinate '{w.text}' is given twice")
    if not link_names:
        report.error(Span(1, 1), "no links: declare the rigid members with 'link NAME J=...'")
    if report.diagnostics:
        return None
    return Mechanism(
        name=title or Path(filename).stem,
        links=tuple(links),
        planetaries=tuple(planetaries),
        gear_pairs=tuple(pairs),
        elements=tuple(elements),
        input=inputs[0].text,
        output=outputs[0].text,
        loads=tuple(loads),
        gears=tuple(gears),
        modes=tuple(modes),
        coordinates=tuple(coord_texts),
        stepped=tuple(stepped),
        shares=shares,
        source=filename,
        text=report.text,
    )


def _stepped(stmt: _Statement, params: dict, report: _Reporter, link_refs: list) -> SteppedPlanetary | None:
    """The stepped-pinion planetary of a ``stepped`` statement, or ``None`` after reporting why not."""
    name = stmt.words[0].text
    before = len(report.diagnostics)
    carrier = params.get("carrier")
    if carrier is not None:
        link_refs.append((carrier, True))
    members = []
    for role in STEPPED_MEMBERS:
        teeth = ("Ns" if role.startswith("sun") else "Nr") + role[-1]
        if role in params:
            link_refs.append((params[role], True))
            if teeth not in stmt.params:
                report.error(params[role].span, f"stepped {name}: {role}= needs its tooth count {teeth}=...")
            elif teeth in params:
                members.append((role, params[role], params[teeth]))
        elif teeth in stmt.params:
            report.error(stmt.params[teeth + "@key"][0].span, f"stepped {name}: {teeth}= is the tooth count of {role}: "
                                                              f"give {role}=LINK too")
    if len(members) + sum(1 for r in STEPPED_MEMBERS if r in params and r not in (m[0] for m in members)) < 2:
        report.error(stmt.span, f"stepped {name} needs two to four central gears: sun1=, sun2=, ring1=, ring2= "
                                f"(the digit is the pinion step they mesh)")
    for step in ("1", "2"):
        used = any(role.endswith(step) for role in STEPPED_MEMBERS if role in params)
        key = f"Np{step}"
        if used and key not in stmt.params:
            report.error(stmt.span, f"stepped {name} needs {key}=... (the teeth of pinion step {step})")
        elif key in stmt.params and not used:
            report.error(stmt.params[key + "@key"][0].span, f"stepped {name}: {key}= but no sun or ring meshes step {step}")
    words = ([carrier] if carrier is not None else []) + [m[1] for m in members]
    texts = [w.text for w in words]
    for w in words:
        if texts.count(w.text) > 1 and w is words[texts.index(w.text)]:
            report.error(w.span, f"stepped {name}: '{w.text}' is used twice (carrier and central gears are different links)")
    np = {"1": params.get("Np1"), "2": params.get("Np2")}
    for role, link, teeth in members:
        step = np[role[-1]]
        if role.startswith("ring") and step is not None and teeth <= step:
            report.error(link.span, f"stepped {name}: {role} teeth {teeth} must exceed the teeth of pinion step "
                                    f"{role[-1]} (Np{role[-1]}={step}) that mesh inside it")
    speeds = {}
    for role, link, teeth in members:
        if np[role[-1]] is not None:
            key = (role.startswith("ring"), teeth * np["2" if role.endswith("1") else "1"] if None not in np.values() else teeth)
            if key in speeds:
                report.error(link.span, f"stepped {name}: {role} and {speeds[key]} would turn together (same ratio to "
                                        f"the pinion): one constraint too few; use one link")
            speeds[key] = role
    if len(report.diagnostics) > before or carrier is None:
        return None
    return SteppedPlanetary(name, carrier.text, tuple((r, w.text, t) for r, w, t in members),
                            params.get("Np1"), params.get("Np2"), stmt.words[0].span, eta0=params.get("eta0"))


def parse_mechanism(text: str, filename: str = "<string>", unknown_teeth: bool = False) -> Mechanism:
    """Parse and validate ``.mech`` text.

    ``unknown_teeth`` accepts planetary tooth counts written ``?`` or ``a..b`` (for
    :mod:`transgen.synthesis`; the counts are ``None`` in the model); otherwise they are errors.

    Raises
    ------
    MechSyntaxError, MechValidationError
        With every problem found, each as ``FILE:LINE:COL: error: message``.

    Examples
    --------
    >>> m = parse_mechanism('''
    ... link A J=1
    ... link B J=2
    ... gears G A B N1=20 N2=40
    ... input A
    ... output B
    ... ''')
    >>> [link.name for link in m.links], m.gear_pairs[0].mesh
    (['A', 'B'], 'external')
    """
    tree = parse_tree(text, filename)
    report = _Reporter(filename, text)
    mechanism = _resolve(_statements(tree, report), report, filename, unknown_teeth)
    if report.diagnostics:
        raise MechValidationError(report.diagnostics)
    assert mechanism is not None
    return mechanism


def load_mechanism(path: str | Path, unknown_teeth: bool = False) -> Mechanism:
    """Read and parse a ``.mech`` file (``unknown_teeth`` as in :func:`parse_mechanism`).

    A bare name such as ``"ht740"`` or ``"ht740.mech"`` that is not an existing file is looked
    up in the bundled library (:mod:`transgen.library`).
    """
    path = Path(path)
    hint = ""
    if not path.exists():
        from .library import bundled_mechanisms, bundled_path

        found = bundled_path(path.name)
        if found is not None:
            path = found
        elif path.suffix in ("", ".mech"):
            hint = _suggest(path.stem, bundled_mechanisms())
            hint = f"{hint[:-1]} (a bundled mechanism, see 'transgen list')?" if hint else ""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise MechSyntaxError([Diagnostic(str(path), 1, 1, f"not a text file ({exc.reason})")]) from None
    except OSError as exc:
        raise MechSyntaxError([Diagnostic(str(path), 1, 1, f"cannot read file: {exc.strerror}{hint}")]) from None
    return parse_mechanism(text, str(path), unknown_teeth)
