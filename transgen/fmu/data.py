"""What an FMU of a transmission holds, as plain data: the tables the generated C code reads.

:func:`fmu_data` takes the simulator's own :class:`~transgen.sim.model.transmission.Transmission` (the
per-mode matrices ``B``, ``C``, ``D`` of every lock set, the elements, the groups in parallel)
and, from a scenario, its time signals; it computes nothing the simulator does not, so that the
FMU and ``transgen simulate`` run on the same numbers. Units SI: speeds rad/s, torques N*m,
inertias kg*m^2. The mode decision itself is the C port of
:meth:`Transmission.decide <transgen.sim.model.transmission.Transmission.decide>` (``c/tg_model.c``);
what it needs from the gearing alone (which lock is implied by the others, the lock sets that
are no mode) is tabulated here with the simulator's functions.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from transgen.errors import ModeError, TransgenError
from transgen.kinematics import constraint_matrix, numeric_rank

__all__ = ["FmuData", "FmuInput", "FmuError", "fmu_data", "input_torques", "torque_rows", "mode_matrices",
           "MAX_ELEMENTS", "CS_STEP"]

#: The most shift elements an FMU holds: every lock set (2^n) is tabulated.
MAX_ELEMENTS = 10
#: The largest internal step [s] of the co-simulation integrator (a parameter of the FMU).
CS_STEP = 2.5e-4


class FmuError(TransgenError, ValueError):
    """A transmission or scenario that cannot be exported as an FMU (bad input: exit 2)."""


@dataclass(frozen=True)
class FmuInput:
    """One input of the FMU: ``name`` (``T_in``, ``T_out``, a named load, ``apply_<element>``),
    the column of the mode matrices' input vector it adds to (None for an apply), the element
    whose apply it is (None otherwise), its start value and its built-in signal (a
    :class:`~transgen.sim.core.signals.Signal`, or None: the input is what the importer sets)."""

    name: str
    column: int | None
    element: int | None
    start: float
    signal: object | None
    unit: str
    description: str


@dataclass
class FmuData:
    """The tables of one FMU (see the module docstring); ``modes[mask]`` is None for a lock set
    that is no mode (its locked torques are not unique), else ``(name, coords, B, C, D, rows, E)``
    with ``rows`` the ``(members, signs)`` of each row of ``D`` and ``E`` the rows of ``D``'s
    solve (see :func:`mode_matrices`); ``F`` maps the input vector to the link torques."""

    title: str
    model_name: str
    links: list[str]
    inertias: list[float]
    elements: list[dict]
    P: np.ndarray
    groups: list[tuple[tuple[int, ...], tuple[int, ...]]]
    n_u: int
    modes: list
    implied: np.ndarray
    gears: list[tuple[str, int]]
    inputs: list[FmuInput]
    w0: list[float]
    slip_tol: float
    breakpoints: list[float] = field(default_factory=list)
    source: str = ""
    driveline: dict | None = None
    engine: dict | None = None
    schedule: dict | None = None
    stop_time: float | None = None  # the scenario's t_end [s]: the FMU's default experiment
    rtol: float | None = None  # the scenario's relative tolerance: the default experiment's
    F: np.ndarray | None = None  # n_links x n_u: the torque of each input on each link

    @property
    def n_indicators(self) -> int:
        """Two event indicators per element, and an upshift, a downshift and an ease one with a schedule."""
        return 2 * len(self.elements) + (3 if self.schedule else 0)

    @property
    def engine_state(self) -> bool:
        """Whether the engine speed is a state (an engine behind a torque converter)."""
        return bool(self.engine) and self.engine["kind"] == "converter"

    @property
    def n_states(self) -> int:
        """The continuous states: every link speed, then the engine speed (behind a converter),
        then the driveline's twist and vehicle-side speed."""
        return len(self.links) + self.engine_state + (2 if self.driveline else 0)

    @property
    def driveline_state(self) -> int:
        """The index of the driveshaft twist in the state vector."""
        return len(self.links) + self.engine_state

    @property
    def mode_masks(self) -> list[int]:
        """The lock sets (bit masks over the elements) that are modes, in increasing order: the
        FMU's ``mode`` output is the position of the current one in this list."""
        return [mask for mask, m in enumerate(self.modes) if m is not None]

    def mode_label(self, mask: int) -> str:
        """The mode's name as the simulator prints it, with its locked elements."""
        name, locked = self.modes[mask][0], self.lock_names(mask)
        return name if name == locked else f"{name} ({locked})"

    def lock_names(self, mask: int) -> str:
        return "+".join(e["name"] for i, e in enumerate(self.elements) if mask >> i & 1) or "none"

    def gear_of(self, mask: int) -> int:
        """1 + the position in the gear table of the gear that locks exactly ``mask``, else 0."""
        names = {e["name"] for i, e in enumerate(self.elements) if mask >> i & 1}
        for k, (_, engaged) in enumerate(self.gears):
            if set(engaged) == names:
                return k + 1
        return 0

    def guid(self, extra: str = "") -> str:
        """A GUID from the model's content (the same model gives the same GUID: deterministic)."""
        h = hashlib.sha256()
        h.update(repr((self.title, self.links, self.inertias, self.elements, self.P.tolist(), self.groups,
                       [None if m is None else (m[0], m[1], m[2].tolist(), m[3].tolist(), m[4].tolist(), m[5])
                        for m in self.modes], [(i.name, i.start, repr(i.signal)) for i in self.inputs],
                       self.w0, self.slip_tol, self.breakpoints, self.driveline, self.engine, repr(self.schedule), extra)).encode())
        d = h.hexdigest()
        return "{" + f"{d[:8]}-{d[8:12]}-{d[12:16]}-{d[16:20]}-{d[20:32]}" + "}"


def fmu_data(tr, model_name: str, title: str, signals: dict | None = None, w0=None, slip_tol: float = 1e-7,
             t_end: float | None = None, source: str = "", driveline=None, engine=None,
             schedule=None, rtol: float | None = None) -> FmuData:
    """The FMU tables of the transmission ``tr`` (:class:`~transgen.sim.model.transmission.Transmission`).

    ``signals``: built-in signals by input name (``T_in``, ``T_out``, ``apply_<element>``): the
    input follows it while the importer leaves it unset; ``w0``: initial link speeds [rad/s];
    ``t_end``: the end of the breakpoint window for periodic signals [s]; ``driveline``: a
    :class:`~transgen.sim.model.components.Driveline` on the output (its shaft torque is ``T_out``, its
    twist and vehicle-side speed are states); ``engine``: an
    :class:`~transgen.sim.model.components.EngineOnLink` or
    :class:`~transgen.sim.model.components.EngineWithConverter` on the input (``T_in``; its throttle and
    torque request are inputs, with their signals as defaults); ``schedule``: an
    :class:`~transgen.sim.control.schedule.AutoShift` (its shift lines, templates and gear sequence)."""
    signals = dict(signals or {})
    n = len(tr.elements)
    if n > MAX_ELEMENTS:
        raise FmuError(f"{model_name}: {n} shift elements; an FMU holds at most {MAX_ELEMENTS} "
                       f"(every lock set is tabulated)")
    modes = []
    F = input_torques(tr)
    gear_rows = constraint_matrix(tr.graph, [])
    for mask in range(1 << n):
        locked = frozenset(i for i in range(n) if mask >> i & 1)
        try:
            m = tr.mode(locked)
        except ModeError:
            modes.append(None)
            continue
        rows = [(tuple(int(i) for i in grp), tuple(int(s) for s in sg)) for grp, sg in zip(m.groups, m.signs)]
        if [r[0][0] for r in rows] != list(m.locked_order):
            raise FmuError(f"{model_name}: mode {tr.mode_name(locked)}: the rows of D are not in the order of "
                           f"their representatives")  # pragma: no cover - a property of transmission.py
        modes.append((tr.mode_name(locked), [int(k) for k in m.coords], np.asarray(m.B, float),
                      np.asarray(m.C, float), np.asarray(m.D, float), rows,
                      torque_rows(gear_rows, tr.P[list(m.locked_order)])))
    groups = [(tuple(int(i) for i in mem), tuple(int(s) for s in sg)) for mem, sg in tr.groups]
    if sorted(i for mem, _ in groups for i in mem) != list(range(n)):
        raise FmuError(f"{model_name}: every element must be in exactly one locking group")  # pragma: no cover
    implied = np.zeros((1 << n, max(1, len(groups))), dtype=np.uint8)
    for rest in range(1 << n):
        names = [tr.elements[i].name for i in range(n) if rest >> i & 1]
        a = constraint_matrix(tr.graph, names)
        rank = numeric_rank(a)
        for g, (members, _) in enumerate(groups):
            if rest & sum(1 << i for i in members):
                continue  # never asked: the group is taken out of the rest first
            implied[rest, g] = numeric_rank(np.vstack([a, tr.P[members[0]]])) == rank
    elements = [{"name": e.name, "kind": e.code, "free": int(e.free), "static": float(e.static),
                 "dynamic": float(e.dynamic), "gain": float(e.gain), "energizing": int(e.energizing),
                 "column": int(tr.element_input[i]), "kind_name": e.kind}
                for i, e in enumerate(tr.elements)]
    for e in tr.elements:
        if e.friction is not None:
            raise FmuError(f"{model_name}: element {e.name} has a friction table (slip-dependent friction): "
                           f"not supported by the FMU export")
    inputs = []
    for col, name in enumerate(tr.inputs):
        if name.startswith("t_") and name[2:] in tr.element_index:
            continue
        if name == "T_out" and driveline is not None:
            continue
        if name == "T_in" and engine is not None:
            continue
        what = {"T_in": "input torque on the input link (drives)",
                "T_out": "load torque delivered by the output link (acts -T_out on it)"}.get(name, "external torque")
        sig = signals.pop(name, None)
        inputs.append(FmuInput(name, col, None, _start(sig), sig, "N.m", what))
    for i, e in enumerate(tr.elements):
        if e.kind == "oneway":
            continue
        name = f"apply_{e.name}"
        sig = signals.pop(name, None)
        inputs.append(FmuInput(name, None, i, _start(sig), sig, "1",
                               f"apply fraction of {e.kind} {e.name} (capacity = apply x capacity); <= 0: released"))
    eng = None
    if engine is not None:
        eng = _engine(engine, tr)
        eng["throttle_input"] = len(inputs)
        inputs.append(FmuInput("throttle", None, None, _start(engine.throttle), engine.throttle, "1",
                               "throttle demand [0-1] of the engine map (before the idle governor)"))
        eng["request_input"] = -1
        if engine.request is not None:
            eng["request_input"] = len(inputs)
            inputs.append(FmuInput("torque_request", None, None, _start(engine.request), engine.request, "1",
                                   "torque-request factor of the shifts (1: none)"))
    sched = None if schedule is None else _schedule(schedule, tr, engine, inputs)
    if signals:
        raise FmuError(f"{model_name}: no input for the signal(s) {', '.join(sorted(signals))}")
    points = set()
    for inp in inputs:
        if inp.signal is not None:
            try:
                points.update(inp.signal.breakpoints())
            except ValueError:  # periodic: infinitely many
                if t_end is None:
                    raise FmuError(f"{model_name}: input {inp.name}: a periodic signal needs the scenario's end time")
                points.update(inp.signal.breakpoints(0.0, t_end))
    w0 = [0.0] * len(tr.links) if w0 is None else [float(x) for x in w0]
    dl = None
    if driveline is not None:
        dl = {"output": int(driveline.output), "stiffness": float(driveline.stiffness),
              "damping": float(driveline.damping), "J_v": float(driveline.J_v), "J_out": float(driveline.J_out), "mass": float(driveline.mass),
              "rolling": float(driveline.rolling), "grade": float(driveline.grade),
              "air_density": float(driveline.air_density), "cd_a": float(driveline.cd_a),
              "wheel_radius": float(driveline.wheel_radius), "final_drive": float(driveline.final_drive),
              "column": int(tr.input_index["T_out"])}
    if eng is not None and eng["kind"] == "converter":
        w0 = w0 + [float(x) for x in engine.initial_state(np.asarray(w0))]
    if driveline is not None:
        w0 = w0 + [float(x) for x in driveline.initial_state(np.asarray(w0[:len(tr.links)]))]
    gears = [(g.name, tuple(g.engaged)) for g in tr.mech.gears if g.kind == "gear"]
    return FmuData(title, model_name, list(tr.links), [float(x) for x in tr.inertia], elements, np.asarray(tr.P, float),
                   groups, len(tr.inputs), modes, implied, gears, inputs, w0, float(slip_tol),
                   sorted(float(p) for p in points if math.isfinite(p)), source, dl, eng, sched,
                   None if t_end is None else float(t_end), None if rtol is None else float(rtol), F)


def input_torques(tr) -> np.ndarray:
    """``F`` (links x inputs): the torque each input puts on each link [N*m per N*m]. ``T_in``
    and named loads drive their link (+1), ``T_out`` acts -1 on the output link, an element's
    torque ``t_e`` (from link1 to link2) acts ``-P[e]`` (it opposes the slip ``P[e] @ w``)."""
    F = np.zeros((len(tr.links), len(tr.inputs)))
    external = {t.name: t for t in tr.mech.torques}
    for j, name in enumerate(tr.inputs):
        if name.startswith("t_") and name[2:] in tr.element_index:
            F[:, j] = -tr.P[tr.element_index[name[2:]]]
        elif name in external:
            F[tr.link_index[external[name].link], j] = external[name].sign
        else:  # pragma: no cover - the state space has no other inputs
            raise FmuError(f"input {name}: not an external or element torque")
    return F


def torque_rows(gear_rows: np.ndarray, locked_rows: np.ndarray) -> np.ndarray:
    """``E``: the rows of the pseudo-inverse of ``[G^T P_L^T]`` (the gear constraints ``G`` and
    the locked representatives' slip rows ``P_L``, both over the links) that give the locked
    torques: the reactions ``x`` of ``G^T mu + P_L^T t = R`` are unique when the mode is, and
    depend on the gearing alone, so :func:`mode_matrices` takes new inertias without them."""
    if not len(locked_rows):
        return np.zeros((0, gear_rows.shape[1]))
    K = np.hstack([gear_rows.T, locked_rows.T])
    return np.linalg.pinv(K)[gear_rows.shape[0]:]


def mode_matrices(C: np.ndarray, F: np.ndarray, E: np.ndarray, J, locked_columns) -> tuple[np.ndarray, np.ndarray]:
    """``(B, D)`` of a mode from its kinematics ``C`` (w = C q), the inputs' link torques ``F``,
    its torque rows ``E`` and the link inertias ``J`` [kg*m^2]: the equations of motion
    ``J dw/dt = F u - P_L^T t - G^T mu`` with ``w = C q`` give ``dq/dt = (C^T J C)^-1 C^T F u = B u``
    and the locked torques ``t = E (F - J C B) u = D u``. The columns of the locked elements'
    own torques (``locked_columns``) are no inputs of the mode (zero). Equal to the simulator's
    matrices (tested); the FMU's C runtime computes the same, so its inertias are parameters."""
    F = np.array(F, float)
    F[:, list(locked_columns)] = 0.0
    J = np.diag(np.asarray(J, float))
    B = np.linalg.solve(C.T @ J @ C, C.T @ F) if C.shape[1] else np.zeros((0, F.shape[1]))
    return B, E @ (F - J @ C @ B)


def _engine(engine, tr) -> dict:
    """The numbers of an engine map (and its converter) for the C code."""
    from transgen.sim.model.components import EngineMap, EngineWithConverter

    if type(engine.engine) is not EngineMap:
        raise FmuError(f"the engine model {type(engine.engine).__name__} cannot be exported (only a torque map)")
    m = engine.engine
    out = {"kind": "converter" if isinstance(engine, EngineWithConverter) else "link", "link": int(engine.link),
           "column": int(tr.input_index["T_in"]), "speeds": list(m.speeds), "throttles": list(m.throttles),
           "table": [x for row in m.torque for x in row], "idle": float(engine.idle), "J": 0.0}
    if out["kind"] == "converter":
        if not hasattr(engine.converter, "tables"):
            raise FmuError(f"the converter model {type(engine.converter).__name__} cannot be exported")
        sr, c, ratio, csr, cc = engine.converter.tables()
        out.update(idle=float(engine.idle), J=float(engine.J_engine), sr=list(sr), c=list(c), tr=list(ratio),
                   csr=list(csr), cc=list(cc))
    return out


def _schedule(auto, tr, engine, inputs) -> dict:
    """The numbers of an automatic shift schedule (:class:`~transgen.sim.control.schedule.AutoShift`) for
    the C code: the shifts up the order, then down, each with its oncoming and offgoing elements
    (bit masks, one-way clutches left out) and its template's apply numbers."""
    from transgen.sim.control.schedule import ShiftTemplate, gear_swap

    oneway = frozenset(e.name for e in tr.elements if e.kind == "oneway")
    fields = ("fill_time", "fill_level", "ramp_time", "ramp_end", "hold_time", "final_time", "offgoing_delay",
              "offgoing_level", "offgoing_ramp", "ease_slip", "ease_time", "ease_level")
    templates, shifts = [], []
    pairs = list(zip(auto.order, auto.order[1:])) + [(b, a) for a, b in zip(auto.order, auto.order[1:])]
    for source, target in pairs:
        template = auto.templates.get(f"{source}-{target}", auto.template)
        if not isinstance(template, ShiftTemplate) or template.torque_intervention:
            raise FmuError(f"shift {source}-{target}: an automatic schedule's engine torque intervention cannot be "
                           f"exported yet")
        numbers = [float(getattr(template, f)) for f in fields]
        if numbers not in templates:
            templates.append(numbers)
        on, off = gear_swap(auto.gears, source, target, oneway, auto.lockup)
        shifts.append((sum(1 << tr.element_index[n] for n in on), sum(1 << tr.element_index[n] for n in off),
                       templates.index(numbers)))
    throttle_in = -1
    if engine is not None and auto.throttle == engine.throttle:
        throttle_in = next(k for k, i in enumerate(inputs) if i.name == "throttle")
    return {"order": list(auto.order), "gear0": auto.order.index(auto.gear), "output": int(auto.output),
            "throttle_points": [float(x) for x in auto.throttle_points],
            "up": [float(x) for row in auto.upshift for x in row], "down": [float(x) for row in auto.downshift for x in row],
            "min_interval": float(auto.min_interval), "templates": templates, "shifts": shifts,
            "throttle_input": throttle_in, "throttle": auto.throttle}


def _start(signal) -> float:
    return 0.0 if signal is None else float(signal.value(0.0))
