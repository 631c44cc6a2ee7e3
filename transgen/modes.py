"""Modes of operation, their degrees of freedom, and generalized coordinates
(thesis sections 3.2.3, 3.2.5, 3.3.2 and 3.4.2).

A *mode* is a set of locked shift elements; every other element slips (or is open) and its
torque is an input. :func:`select_modes` chooses which modes to model:

* ``"default"``: the declared forward gears, then every mode a shift between consecutive forward
  gears can pass through (:func:`shift_modes`: the speed phase — for a single swap the
  one-element-less mode — and, with one-way clutches, groups in parallel and elements in series,
  the modes where one of them has locked or released by itself), then the neutrals
  (declared with ``neutral``, or else the elements shared by the first gear and a reverse gear,
  with any number of degrees of freedom: :func:`default_neutral`) and the modes between it and
  first and reverse gear, then the reverse gears, then the alternative gears (``gear L = ...
  alternative``: no speed phase) — for the HT-740 exactly the thesis' seven modes M1-M7. Gears
  with idle members (:mod:`transgen.idle`) are gears here like any other;
* ``"declared"``: the ``mode`` statements of the file (the default when there are any);
* ``"all"``: every combination of locked elements (also the default of a mechanism without a
  gear table, such as a benchmark chain of clutches).

Elements in parallel (the same two links: :class:`~transgen.equations.LockingGroup`) lock one
motion, as one constraint. A one-way clutch beside a locked element is engaged too (it holds in
its locking direction whenever its group does), so every selection completes each locked set
with those one-way clutches (:func:`~transgen.equations.complete_locked`; e.g. a reverse gear
``DIR BLR`` with a one-way clutch ``OWC`` beside ``BLR`` is the mode ``DIR BLR OWC``): the
modelled modes are the states the simulator can be in.

:func:`mode_model` solves a mode's equations (:mod:`transgen.equations`); its DOF is
``rank(G_accel)`` (eq. 3.12 context), cross-checked with the kinematic DOF.

Generalized coordinates ``q`` (link speeds) are valid when, for every mode,
``rank(G_accel,gc) == rank(G_accel)`` (eq. 3.12), with ``len(q)`` equal to the largest DOF; a mode
with fewer DOF uses the first subset of ``q`` (in the given order) whose rows span its
``G_accel``, so the coordinates of lower-DOF modes are subsets of ``q`` (the nesting rule of 3.2.3).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .blas import one_blas_thread
from .equations import (LockingGroup, ModeEquations, assemble, complete_locked, diagnose_singular, locked_constraints,
                        undetermined_links,
                        solve)
from .errors import ModeError
from .graph import bond_graph
from .idle import gear_check
from .kinematics import analyze, engaged_combinations, numeric_rank
from .model import Mechanism
from .names import mode_names

if TYPE_CHECKING:
    from .graph import Graph

__all__ = [
    "Mode",
    "ModeModel",
    "select_modes",
    "mode_model",
    "mode_models",
    "coordinate_subset",
    "check_coordinates",
    "valid_coordinate_sets",
    "default_coordinates",
    "default_neutral",
    "neutral_note",
    "massless_problems",
]


@dataclass(frozen=True)
class Mode:
    """A mode of operation: ``locked`` shift elements; ``label`` says why it is modelled;
    ``gear``: the gear-table row (gear or neutral) it is, else None (:meth:`transgen.names.ModeNames.gear`),
    so that a mode of any selection (``M10`` of ``"all"``) is known by the gear a user names."""

    name: str
    locked: tuple[str, ...]
    label: str = ""
    gear: str | None = None

    @property
    def key(self) -> frozenset:
        return frozenset(self.locked)


@dataclass(frozen=True)
class ModeModel:
    """A mode with its kinematics and (when they exist) its solved equations.

    ``dof`` is ``rank(G_accel)`` when the equations solve, else the kinematic DOF;
    ``kinematic_dof`` is ``n_links - rank(A)``; ``problem`` explains a mode that cannot be
    modelled (non-unique locked torques, undetermined massless links), else ``""``.
    ``groups``: the mode's constraints (:func:`transgen.equations.locked_constraints`), one per
    locked element or group of locked elements in parallel.
    """

    mode: Mode
    kind: str
    dof: int
    kinematic_dof: int
    equations: ModeEquations | None = field(default=None, repr=False)
    problem: str = ""
    symbolic_equations: ModeEquations | None = field(default=None, repr=False)
    groups: tuple[LockingGroup, ...] = field(default=(), repr=False)
    idle: tuple[str, ...] = ()
    """Idle members (links) of a gear mode (:mod:`transgen.idle`): the ``dof - 1`` extra degrees
    of freedom that carry no torque."""

    @property
    def name(self) -> str:
        return self.mode.name

    @property
    def locked(self) -> tuple[str, ...]:
        return self.mode.locked

    @property
    def parallel(self) -> tuple[LockingGroup, ...]:
        """The locked groups of elements in parallel (two or more members, one constraint)."""
        return tuple(grp for grp in self.groups if len(grp.members) > 1)


def select_modes(mech: Mechanism, which: str = "auto") -> list[Mode]:
    """The modes to model: ``"auto"`` (declared modes if any, else default), ``"default"``,
    ``"declared"`` or ``"all"``; named M1, M2, ... unless declared with names."""
    if which == "auto":
        which = "declared" if mech.modes else "default"
    g = bond_graph(mech)
    if which == "declared":
        if not mech.modes:
            raise ModeError("the mode selection 'declared' needs 'mode NAME = ELEMENTS' statements, and the "
                            "mechanism declares none: choose 'auto' (the default), 'default' or 'all'")
        return _with_gears(mech, [Mode(d.name, complete_locked(g, d.locked), "declared") for d in mech.modes])
    if which == "all":
        names = list(mech.element_names)
        combos = {tuple(sorted(complete_locked(g, c), key=names.index)): None for c in engaged_combinations(names)}
        return _with_gears(mech, [Mode(f"M{i + 1}", c, "") for i, c in enumerate(combos)])
    if which != "default":
        raise ValueError(f"unknown mode selection {which!r}")
    if not any(g.kind == "gear" for g in mech.gears):
        return select_modes(mech, "all")  # no gear table: nothing to choose from
    forward, reverse, alternative = [], [], []
    for gear in mech.gears:
        if gear.kind != "gear":
            continue
        ratio = analyze(mech, gear.engaged, g).ratio
        if gear.alternative:
            alternative.append(gear)
        else:
            (reverse if ratio is not None and ratio < 0 else forward).append(gear)
    chosen: list[tuple[str, tuple[str, ...]]] = [(f"gear {gear.name}", gear.engaged) for gear in forward]
    for a, b in zip(forward, forward[1:]):
        chosen += [(label, locked) for label, locked in shift_modes(mech, a.name, a.engaged, b.name, b.engaged, g)]
    neutrals = [(f"neutral {n.name}", n.engaged) for n in mech.neutrals]
    if not neutrals and forward:
        for r in reverse:
            common = default_neutral(mech, forward[0].engaged, r.engaged, g)
            if common is not None:
                neutrals.append((f"neutral {forward[0].name}-{r.name}", common))
                break  # one neutral: with the first reverse gear that gives one
    chosen += neutrals
    if neutrals:  # engaging first and reverse from the neutral: the modes in between
        name, locked = (mech.neutrals[0].name if mech.neutrals else "N"), neutrals[0][1]
        for gear in forward[:1] + reverse:
            chosen += shift_modes(mech, name, locked, gear.name, gear.engaged, g, label="engagement")
    chosen += [(f"reverse {gear.name}", gear.engaged) for gear in reverse]
    chosen += [(f"alternative gear {gear.name}", gear.engaged) for gear in alternative]
    labels: dict[frozenset, list[str]] = {}
    order: list[tuple[str, ...]] = []
    for label, locked in chosen:
        locked = complete_locked(g, locked)
        key = frozenset(locked)
        if key not in labels:
            labels[key] = []
            order.append(tuple(locked))
        labels[key].append(label)
    return _with_gears(mech, [Mode(f"M{i + 1}", locked, _join_labels(labels[frozenset(locked)]))
                              for i, locked in enumerate(order)])


def _with_gears(mech: Mechanism, modes: list[Mode]) -> list[Mode]:
    """``modes`` with the gear each one is (:meth:`transgen.names.ModeNames.gear`); an unlabelled one
    (of the ``"all"`` selection) labelled by it (``gear 1``, ``neutral N``)."""
    kinds = {gear.name: gear.kind for gear in mech.gears}
    names = mode_names(mech)
    out = []
    for m in modes:
        gear = names.gear(m.locked)
        label = m.label or (f"{kinds[gear]} {gear}" if gear is not None else "")
        out.append(Mode(m.name, m.locked, label, gear))
    return out


MAX_SHIFT_SPAN = 8
"""Most elements a shift may change (locked on one side only, one-way clutches included) for
:func:`shift_modes` to list every set in between (2^8 sets); beyond, only the speed phase."""


def shift_modes(mech: Mechanism, source: str, a, target: str, b, graph: Graph | None = None,
                label: str = "shift") -> list[tuple[str, tuple[str, ...]]]:
    """``(label, locked)`` of every mode a shift from the locked set ``a`` (gear ``source``) to
    ``b`` (gear ``target``) can pass through besides ``a`` and ``b``: the elements both keep plus
    any subset of those that change (each friction element applies or releases, each one-way
    clutch locks or overruns by itself, the friction member of a group in parallel releases while
    its one-way member holds), completed with the one-way clutches beside locked elements
    (:func:`~transgen.equations.complete_locked`), and kept when it is a gear (idle members
    allowed: :mod:`transgen.idle`) or a neutral (the input and output turn freely: a speed phase)
    whose equations solve. Labelled ``speed phase S-T`` (a neutral, e.g. the classical
    one-element-less mode of a single swap) or ``shift S-T`` (a gear met on the way: a one-way
    clutch locked beside the gear, a brake holding an idle hub); ``label="engagement"`` for the
    shifts out of a neutral. Fewest locked first. Beyond :data:`MAX_SHIFT_SPAN` changing elements
    only the speed phase of the elements both keep."""
    g = bond_graph(mech) if graph is None else graph
    a, b = complete_locked(g, a), complete_locked(g, b)
    names = list(mech.element_names)
    keep = tuple(e for e in names if e in a and e in b)
    change = [e for e in names if (e in a) != (e in b)]
    subsets = ([()] if len(change) > MAX_SHIFT_SPAN else
               [c for r in range(len(change) + 1) for c in itertools.combinations(change, r)])
    ends = {frozenset(a), frozenset(b)}
    out, seen = [], set()
    for extra in subsets:
        locked = tuple(sorted(complete_locked(g, keep + extra), key=names.index))
        key = frozenset(locked)
        if key in ends or key in seen:
            continue
        seen.add(key)
        check = gear_check(mech, locked, g)
        # a speed phase whose massless links are undetermined stays: check and the simulator
        # refuse it by name (massless_problems) instead of failing mid-shift
        if check.kind == "neutral" and (not diagnose_singular(g, locked) or undetermined_links(g, locked)):
            kind = "speed phase" if label == "shift" else label
        elif check.is_gear:
            kind = label
        else:
            continue
        out.append((f"{kind} {source}-{target}", locked))
    return out


def massless_problems(mech: Mechanism, which: str = "auto") -> list:
    """Errors (:class:`~transgen.errors.Diagnostic`) for the modes of the selection ``which``
    that leave the motion of massless links undetermined (no inertia coupled to them: no torque
    accelerates them, the simulator cannot run such a mode), one per mode, located at the link
    statement of the first such link and naming every one. Every combination (``"all"``, or a
    mechanism without gear table) is the simulator's choice among them, not each one a mode it
    must run: then only when no combination can be run."""
    from .errors import Diagnostic

    g = bond_graph(mech)
    modes = select_modes(mech, which)
    found = [(m, undetermined_links(g, m.locked)) for m in modes]
    found = [(m, links) for m, links in found if links]
    every = which == "all" or (which in ("auto", "default") and not mech.modes
                               and not any(x.kind == "gear" for x in mech.gears))
    if every and len(found) < len(modes):
        return []
    out = []
    for m, links in found:
        link = mech.link(links[0])
        what = f"mode {m.name}" + (f" ({m.label})" if m.label else "") + f", {' '.join(m.locked) or 'nothing'} locked"
        out.append(Diagnostic(mech.source, link.span.line, link.span.column,
                              f"{what}: the motion of the massless link(s) {', '.join(links)} is undetermined (no "
                              f"inertia is coupled to it), so the simulator cannot run this mode: give one of them "
                              f"an inertia J > 0", mech.source_line(link.span.line)))
    return out


def default_neutral(mech: Mechanism, first, reverse, graph: Graph | None = None) -> tuple[str, ...] | None:
    """The neutral between first gear ``first`` and reverse gear ``reverse``: the elements they
    share (possibly none: everything open), whatever their DOF (a shift from first to reverse
    through neutral releases every other element), or ``None`` when those elements do not make
    a neutral (the input held, or a ratio fixed) or leave a massless member undetermined."""
    g = bond_graph(mech) if graph is None else graph
    common = tuple(e for e in first if e in reverse)
    if analyze(mech, common, g).kind != "neutral" or diagnose_singular(g, complete_locked(g, common)):
        return None
    return common


def neutral_note(mech: Mechanism) -> str:
    """Why the default mode selection of ``mech`` models no neutral, or ``""`` when it models one
    (or declares its modes, or has no forward gear)."""
    if mech.modes or mech.neutrals:
        return ""
    g = bond_graph(mech)
    gears = [(gear, analyze(mech, gear.engaged, g).ratio) for gear in mech.gears if gear.kind == "gear"
             and not gear.alternative]
    forward = [gear for gear, r in gears if not (r is not None and r < 0)]
    reverse = [gear for gear, r in gears if r is not None and r < 0]
    if not forward:
        return ""
    hint = "declare it with 'neutral N = ELEM ...' to model it"
    if not reverse:
        return f"no neutral is modelled: there is no reverse gear to derive it from (first and reverse share its elements); {hint}"
    if any(default_neutral(mech, forward[0].engaged, r.engaged, g) is not None for r in reverse):
        return ""
    r = reverse[0]
    common = tuple(e for e in forward[0].engaged if e in r.engaged)
    c = analyze(mech, common, g)
    why = (diagnose_singular(g, complete_locked(g, common)) if c.kind == "neutral"
           else f"{c.kind}{' (' + c.detail + ')' if c.detail else ''}{f', ratio {c.ratio:.6g}' if c.ratio is not None else ''}")
    shared = " ".join(common) or "no element"
    return (f"no neutral is modelled: gear {forward[0].name} and reverse {r.name} share {shared}, which is not a "
            f"neutral that can be modelled: {why}; {hint}")


def _join_labels(labels: list[str]) -> str:
    """'speed phase 1-2', 'speed phase 2-3' -> 'speed phase 1-2, 2-3'."""
    out: list[str] = []
    for label in labels:
        head, _, tail = label.rpartition(" ")
        if out and out[-1].startswith(head + " "):
            out[-1] += f", {tail}"
        else:
            out.append(label)
    return "; ".join(out)


def mode_model(mech: Mechanism, mode: Mode, graph: Graph | None = None,
               symbolic: bool | str = False) -> ModeModel:
    """Kinematics and solved equations of ``mode``; a mode that cannot be solved keeps
    ``equations=None`` and says why in ``problem``. ``symbolic`` (True, ``"all"`` or
    ``"inertias"``) also solves the symbolic equations (:func:`transgen.equations.assemble`)."""
    g = bond_graph(mech) if graph is None else graph
    combo = gear_check(mech, mode.locked, g)
    groups = locked_constraints(g, mode.locked)
    problem = diagnose_singular(g, mode.locked)
    if problem:
        return ModeModel(mode, combo.kind, combo.dof, combo.dof, None, problem, groups=groups, idle=combo.idle)
    try:
        eq = solve(assemble(g, mode.locked), g)
    except ModeError as exc:  # singular for a reason the diagnosis did not name
        return ModeModel(mode, combo.kind, combo.dof, combo.dof, None, str(exc), groups=groups, idle=combo.idle)
    dof = numeric_rank(eq.G_accel)
    problem = "" if dof == combo.dof else (
        f"{combo.dof - dof} degree(s) of freedom receive no input torque (rank(G_accel) = {dof} < {combo.dof})")
    symbolic_eq = solve(assemble(g, mode.locked, symbolic=symbolic), g) if symbolic else None
    return ModeModel(mode, combo.kind, dof, combo.dof, eq, problem, symbolic_eq, groups, combo.idle)


@one_blas_thread()
def mode_models(mech: Mechanism, which: str = "auto", symbolic: bool | str = False,
                progress=None) -> list[ModeModel]:
    """:func:`mode_model` of every mode of :func:`select_modes`; ``progress(i, n, mode)``, if
    given, is called before each of the ``n`` modes (symbolic solves take seconds each). The
    small dense linear algebra uses one BLAS thread (:mod:`transgen.blas`)."""
    g = bond_graph(mech)
    modes = select_modes(mech, which)
    out = []
    for i, m in enumerate(modes):
        if progress is not None:
            progress(i, len(modes), m)
        out.append(mode_model(mech, m, g, symbolic))
    return out


def coordinate_subset(model: ModeModel, links: list[str], coords) -> tuple[str, ...]:
    """The coordinates mode ``model`` uses: greedily, in the order of ``coords``, those whose
    ``G_accel`` rows add to the rank, until the mode's DOF is reached."""
    G = model.equations.G_accel
    chosen: list[str] = []
    for c in coords:
        rows = [links.index(x) for x in chosen + [c]]
        if numeric_rank(G[rows]) == len(rows):
            chosen.append(c)
        if len(chosen) == model.dof:
            break
    return tuple(chosen)


def check_coordinates(models: list[ModeModel], links: list[str], coords) -> None:
    """Raise :class:`ModeError` if ``coords`` are not valid generalized coordinates for every
    mode (eq. 3.12), naming the mode that breaks them and why."""
    coords = tuple(coords)
    unknown = [c for c in coords if c not in links]
    if unknown:
        raise ModeError(f"unknown link(s) {', '.join(unknown)} in the coordinates (links: {', '.join(links)})")
    solvable = [m for m in models if m.equations is not None]
    needed = max((m.dof for m in solvable), default=0)
    if len(coords) != needed:
        raise ModeError(f"{len(coords)} coordinate(s) given but the modelled modes need {needed} "
                        f"(the largest number of degrees of freedom, L_n in thesis 3.2.3)")
    for m in solvable:
        used = coordinate_subset(m, links, coords)
        if len(used) < m.dof:
            raise ModeError(
                f"coordinates {', '.join(coords)} are not valid for mode {m.name} ({_locked_text(m)}): "
                f"their rows of G_accel have rank {len(used)} but the mode has {m.dof} degree(s) of freedom "
                f"(rank(G_accel,gc) != rank(G_accel), eq. 3.12): {_why(m, links, coords)}")


def _locked_text(m: ModeModel) -> str:
    return (", ".join(m.locked) + " locked") if m.locked else "nothing locked"


def _why(m: ModeModel, links: list[str], coords) -> str:
    G = m.equations.G_accel
    rows = G[[links.index(c) for c in coords]]
    if np.allclose(rows, 0):
        return "none of them moves in this mode"
    for a, b in itertools.combinations(coords, 2):
        ra, rb = G[links.index(a)], G[links.index(b)]
        if numeric_rank(np.vstack([ra, rb])) < 2:
            return f"{a} and {b} move in a fixed ratio in this mode"
    return "they do not span the mode's motions"


def valid_coordinate_sets(models: list[ModeModel], links: list[str]) -> list[tuple[str, ...]]:
    """Every valid set of generalized coordinates (as the thesis asks a computer to find)."""
    solvable = [m for m in models if m.equations is not None]
    needed = max((m.dof for m in solvable), default=0)
    valid = []
    for combo in itertools.combinations(links, needed):
        if all(len(coordinate_subset(m, links, combo)) == m.dof for m in solvable):
            valid.append(combo)
    return valid


def default_coordinates(models: list[ModeModel], links: list[str], input_link: str, output_link: str) -> tuple[str, ...]:
    """A valid set preferring the input and the output link (as the thesis does), input first."""
    sets = valid_coordinate_sets(models, links)
    if not sets:
        raise ModeError("no valid set of generalized coordinates exists for the modelled modes")

    def score(s):
        return (input_link not in s, output_link not in s, [links.index(x) for x in s])

    best = min(sets, key=score)
    order = [input_link, output_link] + [x for x in links if x not in (input_link, output_link)]
    return tuple(sorted(best, key=order.index))
