"""The generated C of an FMU: ``model_data.h`` (the tables of :class:`~.data.FmuData`) and
``model_signals.h`` (the built-in time signals), read by the model-independent runtime
``c/tg_model.c``. Numbers are written with ``repr`` (shortest round trip: the C double is the
Python float), in a fixed order: the same model gives the same bytes."""
from __future__ import annotations

import math

from .data import CS_STEP, FmuData, FmuError

__all__ = ["value_references", "parameters", "model_data_h", "model_signals_h"]

#: the tunable numbers of a driveline and an engine: (FMU name: the scenario's key, key in
#: FmuData, C macro, unit, bound, description); the C code reads them as ``m->par[k]`` through the macro
_DRIVELINE_PARAMETERS = (
    ("driveline.stiffness", "stiffness", "TG_DL_STIFFNESS", "N.m/rad", "positive", "driveshaft torsional stiffness"),
    ("driveline.damping", "damping", "TG_DL_DAMPING", "N.m.s/rad", "nonnegative", "driveshaft damping"),
    ("driveline.output_inertia", "J_out", "TG_DL_JOUT", "kg.m2", "nonnegative",
     "inertia on the vehicle side of the driveshaft, without the vehicle"),
    ("driveline.vehicle_mass", "mass", "TG_DL_MASS", "kg", "nonnegative", "vehicle mass"),
    ("driveline.wheel_radius", "wheel_radius", "TG_DL_RADIUS", "m", "positive", "rolling radius of the driven wheels"),
    ("driveline.final_drive", "final_drive", "TG_DL_FINAL", "1", "positive", "final-drive ratio (driveshaft / wheel speed)"),
    ("driveline.rolling_resistance", "rolling", "TG_DL_ROLLING", "1", "nonnegative", "rolling-resistance coefficient"),
    ("driveline.cd_a", "cd_a", "TG_DL_CDA", "m2", "nonnegative", "drag coefficient times frontal area"),
    ("driveline.air_density", "air_density", "TG_DL_AIR", "kg/m3", "nonnegative", "air density"),
    ("driveline.grade", "grade", "TG_DL_GRADE", "rad", "grade", "road grade angle (positive uphill)"),
)
_ENGINE_PARAMETERS = (
    ("input.J_engine", "J", "TG_ENG_J", "kg.m2", "positive", "engine inertia with the converter's pump"),
    ("input.idle_speed", "idle", "TG_ENG_IDLE", "rad/s", "nonnegative",
     "idle speed of the governor (the scenario's input.idle_rpm, in rad/s)"),
)


def parameters(d: FmuData) -> list[tuple[str, float, str, str, str, str]]:
    """The tunable parameters besides the capacities and inertias, in value-reference order:
    ``(name, start, C macro, unit, bound, description)`` (bound: ``positive``, ``nonnegative``
    or ``grade``: ``|grade| < pi/2``)."""
    out = []
    if d.driveline:
        out += [(n, float(d.driveline[k]), c, u, b, t) for n, k, c, u, b, t in _DRIVELINE_PARAMETERS]
    if d.engine and d.engine["kind"] == "converter":
        out += [(n, float(d.engine[k]), c, u, b, t) for n, k, c, u, b, t in _ENGINE_PARAMETERS]
    return out


def value_references(d: FmuData) -> dict[str, int]:
    """The first value reference of each kind of variable (one numbering over all types, as FMI
    3.0 requires): speeds (the states), their derivatives, slips, element torques, inputs,
    static and dynamic capacities, inertias, the slip tolerance, the co-simulation step, time, the
    time of the last change of mode,
    the integers ``mode``, ``gear``, ``lockedElements``, the booleans ``locked_<element>``, the event indicators (two per element), and the
    driveline's shaft torque ``T_out`` and ``vehicle_speed``, the engine's ``T_in`` and ``T_engine``."""
    nl, ne, nin, nx = len(d.links), len(d.elements), len(d.inputs), d.n_states
    out = {"W": 0, "DER": nx, "SLIP": 2 * nx, "TORQUE": 2 * nx + ne, "IN": 2 * nx + 2 * ne}
    out["STATIC"] = out["IN"] + nin
    out["DYNAMIC"] = out["STATIC"] + ne
    out["J"] = out["DYNAMIC"] + ne
    out["SLIPTOL"] = out["J"] + nl
    out["CSSTEP"] = out["SLIPTOL"] + 1
    out["TIME"] = out["CSSTEP"] + 1
    out["TEVENT"] = out["TIME"] + 1
    out["INT"] = out["TEVENT"] + 1
    out["BOOL"] = out["INT"] + 3
    out["Z"] = out["BOOL"] + ne
    out["DL"] = out["Z"] + d.n_indicators
    out["ENG"] = out["DL"] + 2
    out["PAR"] = out["ENG"] + 2
    return out


def _num(x: float) -> str:
    if math.isinf(x):
        return "INFINITY" if x > 0 else "(-INFINITY)"
    if math.isnan(x):
        raise FmuError("a NaN in the model data")
    return repr(float(x))


def _array(ctype: str, name: str, values, per_line: int = 8) -> str:
    values = list(values)
    fmt = _num if ctype == "double" else str
    items = [fmt(v) for v in values] or ["0"]  # C has no empty arrays
    lines = [", ".join(items[k:k + per_line]) for k in range(0, len(items), per_line)]
    body = ",\n    ".join(lines)
    return f"static const {ctype} {name}[{len(items)}] = {{\n    {body}\n}};\n"


def _string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def model_data_h(d: FmuData, guid: str) -> str:
    """The tables of ``d`` as C (see ``c/tg_model.c`` for their meaning)."""
    nl, ne, nu, ng = len(d.links), len(d.elements), d.n_u, len(d.groups)
    vr = value_references(d)
    out = [f"/* generated by transgen from {d.source or d.model_name}: do not edit */\n",
           f"#define TG_GUID {_string(guid)}\n", f"#define TG_NL {nl}\n", f"#define TG_NE {ne}\n",
           f"#define TG_NU {nu}\n", f"#define TG_NG {ng}\n", f"#define TG_NIN {len(d.inputs)}\n",
           f"#define TG_NBP {len(d.breakpoints)}\n", f"#define TG_SLIP_TOL {_num(d.slip_tol)}\n",
           f"#define TG_CS_STEP {_num(CS_STEP)}\n", f"#define TG_NX {d.n_states}\n",
           f"#define TG_DRIVELINE {1 if d.driveline else 0}\n"]
    eng = d.engine
    out.append(f"#define TG_ENGINE {0 if not eng else (2 if eng['kind'] == 'converter' else 1)}\n")
    if eng:
        out += [f"#define TG_ENG_X {len(d.links)}\n", f"#define TG_ENG_LINK {eng['link']}\n",
                f"#define TG_ENG_UCOL {eng['column']}\n", f"#define TG_ENG_NS {len(eng['speeds'])}\n",
                f"#define TG_ENG_NT {len(eng['throttles'])}\n", f"#define TG_ENG_THROTTLE_IN {eng['throttle_input']}\n",
                f"#define TG_ENG_REQUEST_IN {eng['request_input']}\n",
                _array("double", "TG_ENG_SPEEDS", eng["speeds"]), _array("double", "TG_ENG_THROTTLES", eng["throttles"]),
                _array("double", "TG_ENG_TABLE", eng["table"])]
        if eng["kind"] == "converter":
            out += [f"#define TG_TC_N {len(eng['sr'])}\n", f"#define TG_TC_NC {len(eng['csr'])}\n"]
            out += [_array("double", f"TG_TC_{k.upper()}", eng[k]) for k in ("sr", "c", "tr", "csr", "cc")]
    sc = d.schedule
    out.append(f"#define TG_SCHEDULE {1 if sc else 0}\n")
    if sc:
        out += [f"#define TG_SCHED_NG {len(sc['order'])}\n", f"#define TG_SCHED_GEAR0 {sc['gear0']}\n",
                f"#define TG_SCHED_OUTPUT {sc['output']}\n", f"#define TG_SCHED_NTHR {len(sc['throttle_points'])}\n",
                f"#define TG_SCHED_MIN_INTERVAL {_num(sc['min_interval'])}\n",
                f"#define TG_SCHED_THROTTLE_IN {sc['throttle_input']}\n",
                f"#define TG_SCHED_SIG {sum(i.signal is not None for i in d.inputs)}\n",
                _array("double", "TG_SCHED_THR", sc["throttle_points"]), _array("double", "TG_SCHED_UP", sc["up"]),
                _array("double", "TG_SCHED_DOWN", sc["down"]),
                _array("double", "TG_SCHED_TEMPLATES", [x for t in sc["templates"] for x in t]),
                _array("unsigned", "TG_SCHED_ON", [on for on, _, _ in sc["shifts"]]),
                _array("unsigned", "TG_SCHED_OFF", [off for _, off, _ in sc["shifts"]]),
                _array("int", "TG_SCHED_TEMPLATE_OF", [k for _, _, k in sc["shifts"]])]
    if d.driveline:
        dl = d.driveline
        out += [f"#define TG_DL_OUTPUT {dl['output']}\n", f"#define TG_DL_UCOL {dl['column']}\n",
                f"#define TG_DL_X {d.driveline_state}\n"]
    out += [f"#define TG_VR_{k} {v}\n" for k, v in vr.items()]
    par = parameters(d)
    if eng and eng["kind"] != "converter":  # the idle governor of an engine on a link: a constant
        out += [f"#define TG_ENG_IDLE {float(eng['idle'])!r}\n"]
    out += [f"#define TG_NPAR {len(par)}\n", _array("double", "TG_PAR0", [p[1] for p in par]),
            _array("int", "TG_PAR_BOUND", [("positive", "nonnegative", "grade").index(p[4]) for p in par])]
    out += [f"#define {p[2]} (m->par[{k}])\n" for k, p in enumerate(par)]
    out.append("static const char *TG_ELEMENT_NAMES[%d] = {%s};\n"
               % (max(1, ne), ", ".join(_string(e["name"]) for e in d.elements) or "0"))
    out.append(_array("int", "TG_KIND", [e["kind"] for e in d.elements]))
    out.append(_array("int", "TG_FREE", [e["free"] for e in d.elements]))
    out.append(_array("int", "TG_ENERGIZING", [e["energizing"] for e in d.elements]))
    out.append(_array("double", "TG_GAIN", [e["gain"] for e in d.elements]))
    out.append(_array("int", "TG_UCOL", [e["column"] for e in d.elements]))
    apply_in = [-1] * ne
    for k, inp in enumerate(d.inputs):
        if inp.element is not None:
            apply_in[inp.element] = k
    out.append(_array("int", "TG_APPLY_IN", apply_in))
    out.append(_array("double", "TG_STATIC0", [e["static"] for e in d.elements]))
    out.append(_array("double", "TG_DYNAMIC0", [e["dynamic"] for e in d.elements]))
    out.append(_array("double", "TG_P", d.P.ravel()))
    starts, members, signs = [0], [], []
    for mem, sg in d.groups:
        members += mem
        signs += sg
        starts.append(len(members))
    out += [_array("int", "TG_GROUP_START", starts), _array("int", "TG_GROUP_MEMBERS", members),
            _array("int", "TG_GROUP_SIGNS", signs)]
    valid, dof, nrow, off = [], [], [], {k: [] for k in ("B", "C", "D", "E", "COORD", "ROW")}
    nb, C, nd, E, coords = 0, [], 0, [], []
    rep, rstart, rcount, rmem, rsign = [], [], [], [], []
    for m in d.modes:
        off["B"].append(nb)
        off["C"].append(len(C))
        off["D"].append(nd)
        off["E"].append(len(E))
        off["COORD"].append(len(coords))
        off["ROW"].append(len(rep))
        if m is None:
            valid.append(0)
            dof.append(0)
            nrow.append(0)
            continue
        _, cs, b, c, dd, rows, e = m
        valid.append(1)
        dof.append(len(cs))
        nrow.append(len(rows))
        coords += cs
        nb += b.size
        C += list(c.reshape(-1))
        nd += dd.size
        E += list(e.reshape(-1))
        for mem, sg in rows:
            rep.append(mem[0])
            rstart.append(len(rmem))
            rcount.append(len(mem))
            rmem += mem
            rsign += sg
    out += [_array("int", "TG_MODE_VALID", valid), _array("int", "TG_MODE_DOF", dof),
            _array("int", "TG_MODE_NROW", nrow)]
    out += [_array("int", f"TG_MODE_{k}_OFF", v) for k, v in off.items()]
    out += [f"#define TG_NB {max(1, nb)}\n", f"#define TG_ND {max(1, nd)}\n", _array("double", "TG_C", C),
            _array("double", "TG_E", E), _array("double", "TG_F", d.F.ravel()),
            _array("int", "TG_COORDS", coords), _array("int", "TG_ROW_REP", rep), _array("int", "TG_ROW_START", rstart),
            _array("int", "TG_ROW_COUNT", rcount), _array("int", "TG_ROW_MEMBERS", rmem),
            _array("int", "TG_ROW_SIGNS", rsign)]
    out.append(_array("unsigned char", "TG_IMPLIED", d.implied.reshape(-1), 32))
    index = {mask: k for k, mask in enumerate(d.mode_masks)}
    out.append(_array("int", "TG_MODE_INDEX", [index.get(mask, -1) for mask in range(len(d.modes))], 16))
    out.append(_array("int", "TG_GEAR_OF_MODE", [d.gear_of(mask) for mask in range(len(d.modes))], 16))
    sig_index, next_sig = [], 0
    for inp in d.inputs:
        sig_index.append(next_sig if inp.signal is not None else -1)
        next_sig += inp.signal is not None
    out += [_array("int", "TG_IN_UCOL", [-1 if i.column is None else i.column for i in d.inputs]),
            _array("int", "TG_IN_SIG", sig_index), _array("double", "TG_IN_START", [i.start for i in d.inputs]),
            _array("double", "TG_W0", d.w0), _array("double", "TG_J0", d.inertias),
            _array("double", "TG_BP", d.breakpoints)]
    return "".join(out)


def model_signals_h(d: FmuData) -> str:
    """``tg_signal(k, t)``: the built-in signal of the k-th input that has one; and
    ``tg_signal_next_edge(t)``: the first edge after ``t`` of the periodic signals among them
    (pulse trains and periodic tables have infinitely many breakpoints: the runtime asks for the
    next one instead of a table)."""
    tables: list[str] = []
    cases, edges = [], []
    k = 0
    for inp in d.inputs:
        if inp.signal is None:
            continue
        cases.append(f"    case {k}: return {_signal_c(inp.signal, tables, inp.name, edges)};  /* {inp.name} */\n")
        k += 1
    if d.schedule:  # the schedule's throttle (for its shift lines), case TG_SCHED_SIG
        cases.append(f"    case {k}: return {_signal_c(d.schedule['throttle'], tables, 'auto_shift throttle', edges)};\n")
    next_edge = "".join(f"    next = fmin(next, {e});\n" for e in edges)
    return ("/* generated by transgen: the built-in time signals of the inputs */\n" + "".join(tables)
            + "static double tg_signal(int k, double t) {\n    (void)t;\n    switch (k) {\n" + "".join(cases)
            + "    default: return 0.0;\n    }\n}\n\n"
            + "static double tg_signal_next_edge(double t) {\n    double next = INFINITY;\n    (void)t;\n"
            + next_edge + "    return next;\n}\n")


#: the signal kinds an FMU builds in
SUPPORTED = "constant, step, ramp, table, sine, pulse, square, periodic, sum, spliced"


def _signal_c(sig, tables: list[str], where: str, edges: list[str]) -> str:
    """A C expression in ``t`` for the signal ``sig`` (the formulas of :mod:`transgen.sim.core.signals`);
    the C expressions of the next edge after ``t`` of its periodic parts are added to ``edges``."""
    form = sig.kernel_form() if hasattr(sig, "kernel_form") else None
    if form is None:
        raise FmuError(f"input {where}: a {type(sig).__name__.lower()} signal cannot be built into an FMU "
                       f"(supported: {SUPPORTED})")
    kind, numbers, parts = form
    n = [_num(x) for x in numbers]
    if kind == "constant":
        return n[0]
    if kind == "step":
        return f"(t >= {n[0]} ? {n[2]} : {n[1]})"
    if kind == "ramp":
        return f"tg_ramp(t, {n[0]}, {n[1]}, {n[2]}, {n[3]})"
    if kind == "table":
        half = len(numbers) // 2
        name = f"TG_SIG{len(tables)}"
        tables.append(_array("double", name + "_T", numbers[:half]) + _array("double", name + "_V", numbers[half:]))
        return f"tg_table(t, {name}_T, {name}_V, {half})"
    if kind == "sine":
        return f"({n[0]} + {n[1]} * sin(2 * 3.141592653589793 * {n[2]} * t + {n[3]}))"
    if kind == "sum":
        return "(0.0 + " + " + ".join(_signal_c(p, tables, where, edges) for p in parts) + ")"
    if kind == "spliced":
        return (f"(t >= {n[0]} ? {_signal_c(parts[1], tables, where, edges)} : "
                f"{_signal_c(parts[0], tables, where, edges)})")
    if kind == "pulse":
        edges.append(f"tg_pulse_next_edge(t, {n[0]}, {n[1]}, {n[4]})")
        return f"tg_pulse(t, {', '.join(n)})"
    if kind == "periodic":
        period, rest = numbers[0], numbers[1:]
        half = len(rest) // 2
        name = f"TG_SIG{len(tables)}"
        first = rest[0]
        offsets = sorted({x - first for x in rest[:half] if x - first < period} | {0.0})
        tables.append(_array("double", name + "_T", rest[:half]) + _array("double", name + "_V", rest[half:])
                      + _array("double", name + "_O", offsets))
        edges.append(f"tg_periodic_next_edge(t, {name}_T, {name}_O, {len(offsets)}, {n[0]})")
        return f"tg_periodic(t, {name}_T, {name}_V, {half}, {n[0]})"
    raise FmuError(f"input {where}: a {kind} signal cannot be built into an FMU (supported: {SUPPORTED})")
