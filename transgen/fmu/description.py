"""``modelDescription.xml`` of a transgen FMU, FMI 2.0 or 3.0, from :class:`~.data.FmuData`.

The variables are named as the simulator's CSV columns: the states ``w_<link>`` [rad/s] (every
link speed: a fixed state vector over all modes), ``slip_<element>``, ``t_<element>`` [N*m],
``locked_<element>``, the inputs ``T_in``, ``T_out`` and ``apply_<element>``, the integer
outputs ``mode`` and ``gear`` (their names in the description), ``lockedElements`` (a bit mask),
and the tunable parameters ``static_<element>``, ``dynamic_<element>`` [N*m], ``J_<link>``
[kg*m^2] and the driveline's and engine's numbers (:func:`~.codegen.parameters`). No timestamp: the
same model gives the same bytes.
"""
from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

from .codegen import parameters, value_references
from .data import CS_STEP, FmuData

__all__ = ["Variable", "variables", "model_description"]

UNITS = {"rad": ("rad", {"rad": 1}), "m/s": ("m/s", {"m": 1, "s": -1}), "rad/s": ("rad/s", {"s": -1, "rad": 1}), "rad/s2": ("rad/s2", {"s": -2, "rad": 1}),
         "N.m": ("N.m", {"kg": 1, "m": 2, "s": -2}), "kg.m2": ("kg.m2", {"kg": 1, "m": 2}), "s": ("s", {"s": 1}),
         "N.m/rad": ("N.m/rad", {"kg": 1, "m": 2, "s": -2, "rad": -1}),
         "N.m.s/rad": ("N.m.s/rad", {"kg": 1, "m": 2, "s": -1, "rad": -1}), "kg": ("kg", {"kg": 1}),
         "m": ("m", {"m": 1}), "m2": ("m2", {"m": 2}), "kg/m3": ("kg/m3", {"kg": 1, "m": -3})}


@dataclass(frozen=True)
class Variable:
    """One variable: ``type`` Real/Integer/Boolean; ``causality``, ``variability``, ``initial``
    as FMI spells them (None: not written); ``derivative_of``: the value reference of the state
    this is the derivative of."""

    name: str
    vr: int
    type: str
    causality: str
    variability: str
    initial: str | None
    start: float | int | bool | None
    unit: str | None
    description: str
    derivative_of: int | None = None


def variables(d: FmuData) -> list[Variable]:
    """Every variable of the FMU, in the order of the model description."""
    vr = value_references(d)
    out: list[Variable] = []
    for k, link in enumerate(d.links):
        out.append(Variable(f"w_{link}", vr["W"] + k, "Real", "output", "continuous", "exact", d.w0[k], "rad/s",
                            f"speed of link {link} (a state; its start value is the initial speed)"))
    nl, xd = len(d.links), d.driveline_state
    if d.engine_state:
        out.append(Variable("omega_engine", vr["W"] + nl, "Real", "output", "continuous", "exact", d.w0[nl], "rad/s",
                            "engine speed (a state; the converter's pump)"))
    if d.driveline:
        out.append(Variable("theta_ds", vr["W"] + xd, "Real", "output", "continuous", "exact", d.w0[xd], "rad",
                            "driveshaft twist, output side minus vehicle side (a state)"))
        out.append(Variable("omega_v", vr["W"] + xd + 1, "Real", "output", "continuous", "exact", d.w0[xd + 1],
                            "rad/s", "vehicle-side speed referred to the driveshaft (a state)"))
    for k, link in enumerate(d.links):
        out.append(Variable(f"der(w_{link})", vr["DER"] + k, "Real", "local", "continuous", "calculated", None,
                            "rad/s2", f"acceleration of link {link}", vr["W"] + k))
    if d.engine_state:
        out.append(Variable("der(omega_engine)", vr["DER"] + nl, "Real", "local", "continuous", "calculated", None,
                            "rad/s2", "engine acceleration", vr["W"] + nl))
    if d.engine:
        out.append(Variable("T_in", vr["ENG"], "Real", "output", "continuous", "calculated", None, "N.m",
                            "torque on the input link: the engine's, or the converter turbine's"))
        out.append(Variable("T_engine", vr["ENG"] + 1, "Real", "output", "continuous", "calculated", None, "N.m",
                            "engine torque from the map (with the idle governor and the torque request)"))
    if d.driveline:
        out.append(Variable("der(theta_ds)", vr["DER"] + xd, "Real", "local", "continuous", "calculated", None,
                            "rad/s", "twist rate of the driveshaft", vr["W"] + xd))
        out.append(Variable("der(omega_v)", vr["DER"] + xd + 1, "Real", "local", "continuous", "calculated", None,
                            "rad/s2", "vehicle-side acceleration referred to the driveshaft", vr["W"] + xd + 1))
        out.append(Variable("T_out", vr["DL"], "Real", "output", "continuous", "calculated", None, "N.m",
                            "driveshaft torque delivered by the output link (k*theta + c*(w_out - omega_v))"))
        out.append(Variable("vehicle_speed", vr["DL"] + 1, "Real", "output", "continuous", "calculated", None,
                            "m/s", "vehicle speed"))
    for i, e in enumerate(d.elements):
        out.append(Variable(f"slip_{e['name']}", vr["SLIP"] + i, "Real", "output", "continuous", "calculated", None,
                            "rad/s", f"slip speed of {e['kind_name']} {e['name']} (link1 - link2)"))
    for i, e in enumerate(d.elements):
        out.append(Variable(f"t_{e['name']}", vr["TORQUE"] + i, "Real", "output", "continuous", "calculated", None,
                            "N.m", f"torque of {e['kind_name']} {e['name']} (from link1 to link2)"))
    for k, inp in enumerate(d.inputs):
        text = inp.description + ("; unconnected, it follows the scenario's signal" if inp.signal is not None else "")
        out.append(Variable(inp.name, vr["IN"] + k, "Real", "input", "continuous", None, inp.start,
                            None if inp.unit == "1" else inp.unit, text))
    for i, e in enumerate(d.elements):
        if e["kind_name"] == "oneway":
            continue
        out.append(Variable(f"static_{e['name']}", vr["STATIC"] + i, "Real", "parameter", "tunable", "exact",
                            e["static"], "N.m", f"static capacity of {e['name']} at full apply (holding limit)"))
        if e["kind_name"] != "dog":
            out.append(Variable(f"dynamic_{e['name']}", vr["DYNAMIC"] + i, "Real", "parameter", "tunable", "exact",
                                e["dynamic"], "N.m", f"dynamic capacity of {e['name']} at full apply (slipping)"))
    for k, link in enumerate(d.links):
        out.append(Variable(f"J_{link}", vr["J"] + k, "Real", "parameter", "tunable", "exact", d.inertias[k], "kg.m2",
                            f"inertia of link {link} (>= 0; the mode matrices follow it)"))
    for k, (name, start, _, unit, _, text) in enumerate(parameters(d)):
        out.append(Variable(name, vr["PAR"] + k, "Real", "parameter", "tunable", "exact", start,
                            None if unit == "1" else unit, text))
    out.append(Variable("slip_tolerance", vr["SLIPTOL"], "Real", "parameter", "fixed", "exact", d.slip_tol, None,
                        "relative slip speed below which an element is at zero slip at an event (transgen "
                        "simulate's slip_tol)"))
    out.append(Variable("cs_max_step", vr["CSSTEP"], "Real", "parameter", "fixed", "exact", CS_STEP, "s",
                        "largest internal step of the co-simulation integrator (events are located inside it)"))
    out.append(Variable("t_mode_change", vr["TEVENT"], "Real", "output", "discrete", "calculated", None, "s",
                        "time of the last change of the locked elements (located inside the step in co-simulation)"))
    labels = "; ".join(f"{k} = {d.mode_label(mask)}" for k, mask in enumerate(d.mode_masks))
    out.append(Variable("mode", vr["INT"], "Integer", "output", "discrete", "calculated", None, None,
                        f"current mode: {labels}"))
    gears = "; ".join(f"{k + 1} = {name}" for k, (name, _) in enumerate(d.gears))
    out.append(Variable("gear", vr["INT"] + 1, "Integer", "output", "discrete", "calculated", None, None,
                        "gear of the table the locked elements make: 0 = none" + (f"; {gears}" if gears else "")))
    bits = ", ".join(f"bit {i} = {e['name']}" for i, e in enumerate(d.elements))
    out.append(Variable("lockedElements", vr["INT"] + 2, "Integer", "output", "discrete", "calculated", None, None,
                        f"locked elements as a bit mask: {bits}"))
    for i, e in enumerate(d.elements):
        out.append(Variable(f"locked_{e['name']}", vr["BOOL"] + i, "Boolean", "output", "discrete", "calculated",
                            None, None, f"{e['name']} is locked"))
    for i, e in enumerate(d.elements):
        out.append(Variable(f"indicator_slip_{e['name']}", vr["Z"] + 2 * i, "Real", "local", "continuous",
                            "calculated", None, None,
                            f"event indicator {2 * i}: slipping, direction x slip of {e['name']} + 1e-3 x slip "
                            f"tolerance (crosses zero: may lock); locked, its row's holding margin (unlocks)"))
        out.append(Variable(f"indicator_apply_{e['name']}", vr["Z"] + 2 * i + 1, "Real", "local", "continuous",
                            "calculated", None, None,
                            f"event indicator {2 * i + 1}: the apply of {e['name']} crossing zero while it slips"))
    if d.schedule:
        for k, kind in enumerate(("upshift", "downshift")):
            out.append(Variable(f"indicator_{kind}", vr["Z"] + 2 * len(d.elements) + k, "Real", "local",
                                "continuous", "calculated", None, None,
                                f"event indicator {2 * len(d.elements) + k}: the automatic schedule's {kind} line "
                                f"crossed (and min_interval passed)"))
        out.append(Variable("indicator_ease", vr["Z"] + 2 * len(d.elements) + 2, "Real", "local", "continuous",
                            "calculated", None, None,
                            f"event indicator {2 * len(d.elements) + 2}: the oncoming slip of an easing shift down "
                            f"to its ease slip (the template's ease_slip of its slip at the command)"))
    return out


def _indicators(d: FmuData) -> str:
    names = []
    for e in d.elements:
        names += [f"indicator_slip_{e['name']}", f"indicator_apply_{e['name']}"]
    return ", ".join(f"{k} = {n}" for k, n in enumerate(names))


def _units(vs: list[Variable], fmi: int) -> str:
    used = sorted({v.unit for v in vs if v.unit})
    lines = ["  <UnitDefinitions>\n"]
    for u in used:
        name, base = UNITS[u]
        attrs = " ".join(f'{k}="{v}"' for k, v in base.items())
        lines.append(f'    <Unit name="{name}">\n      <BaseUnit {attrs}/>\n    </Unit>\n')
    lines.append("  </UnitDefinitions>\n")
    return "".join(lines)


#: the relative tolerance a transmission alone recommends to a Model Exchange importer (its default
#: experiment; a scenario's is its own ``rtol``, at most this): at FMPy's own default (1e-4)
#: CVode's error over a 50 s launch moves a slow unlock by 2 ms
TOLERANCE = 1e-6


def _experiment(d: FmuData) -> str:
    stop = "" if d.stop_time is None else f' stopTime="{d.stop_time!r}"'
    tol = TOLERANCE if d.rtol is None else min(TOLERANCE, d.rtol)
    return f'  <DefaultExperiment startTime="0.0"{stop} tolerance="{tol!r}"/>\n'


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and v in (float("inf"), float("-inf")):
        return "INF" if v > 0 else "-INF"  # xs:double
    return repr(float(v)) if isinstance(v, float) else str(v)


def model_description(d: FmuData, fmi: int, interfaces: tuple[str, ...], guid: str) -> str:
    """The ``modelDescription.xml`` text for FMI ``fmi`` (2 or 3) with ``interfaces`` (``"me"``,
    ``"cs"``)."""
    vs = variables(d)
    ident = d.model_name
    desc = (f"{d.title}: transgen transmission model (modes switched by transgen's own decision). "
            f"Event indicators: {_indicators(d)}")
    return (_fmi2 if fmi == 2 else _fmi3)(d, vs, ident, desc, interfaces, guid)


def _interfaces(ident: str, interfaces, state: str, cs_extra: str) -> str:
    """The ModelExchange and CoSimulation elements (``state``: FMI 2 spells ``FMUstate``, FMI 3
    ``FMUState``)."""
    flags = f'canGetAndSet{state}="true" canSerialize{state}="true"'
    out = ""
    if "me" in interfaces:
        out += f'  <ModelExchange modelIdentifier="{ident}" {flags}/>\n'
    if "cs" in interfaces:
        out += (f'  <CoSimulation modelIdentifier="{ident}" canHandleVariableCommunicationStepSize="true" '
                f'{flags}{cs_extra}/>\n')
    return out


def _fmi2(d, vs, ident, desc, interfaces, guid) -> str:
    head = ['<?xml version="1.0" encoding="UTF-8"?>\n',
            f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(ident)} guid="{guid}"\n'
            f'  description={quoteattr(desc)}\n  generationTool="transgen" variableNamingConvention="flat"\n'
            f'  numberOfEventIndicators="{d.n_indicators}">\n']
    head += [_interfaces(ident, interfaces, "FMUstate", ""), _units(vs, 2), _experiment(d)]
    body = ["  <ModelVariables>\n"]
    index = {}
    for k, v in enumerate(vs, 1):
        index[v.vr] = k
        attrs = f'name={quoteattr(v.name)} valueReference="{v.vr}" description={quoteattr(v.description)} ' \
                f'causality="{v.causality}" variability="{v.variability}"'
        if v.initial and v.causality != "input":
            attrs += f' initial="{v.initial}"'
        inner = ""
        if v.type == "Real":
            if v.unit:
                inner += f' unit="{v.unit}"'
            if v.derivative_of is not None:
                inner += f' derivative="{index[v.derivative_of]}"'
        if v.start is not None:
            inner += f' start="{_fmt(v.start)}"'
        body.append(f"    <ScalarVariable {attrs}>\n      <{v.type}{inner}/>\n    </ScalarVariable>\n")
    body.append("  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n")
    body += [f'      <Unknown index="{index[v.vr]}"/>\n' for v in vs if v.causality == "output"]
    body.append("    </Outputs>\n    <Derivatives>\n")
    body += [f'      <Unknown index="{index[v.vr]}"/>\n' for v in vs if v.derivative_of is not None]
    body.append("    </Derivatives>\n    <InitialUnknowns>\n")
    initial = sorted(index[v.vr] for v in vs if (v.causality == "output" and v.initial == "calculated")
                     or v.derivative_of is not None)
    body += [f'      <Unknown index="{k}"/>\n' for k in initial]
    body.append("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n")
    return "".join(head + body)


def _fmi3(d, vs, ident, desc, interfaces, guid) -> str:
    ne = len(d.elements)
    vr = value_references(d)
    head = ['<?xml version="1.0" encoding="UTF-8"?>\n',
            f'<fmiModelDescription fmiVersion="3.0" modelName={quoteattr(ident)} instantiationToken="{guid}"\n'
            f'  description={quoteattr(desc)}\n  generationTool="transgen" variableNamingConvention="flat">\n']
    head += [_interfaces(ident, interfaces, "FMUState", ' hasEventMode="false"'), _units(vs, 3), _experiment(d)]
    body = ["  <ModelVariables>\n",
            f'    <Float64 name="time" valueReference="{vr["TIME"]}" causality="independent" variability="continuous" '
            f'description="simulation time" unit="s"/>\n']
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
    for v in vs:
        attrs = f'name={quoteattr(v.name)} valueReference="{v.vr}" description={quoteattr(v.description)} ' \
                f'causality="{v.causality}" variability="{v.variability}"'
        if v.initial and v.causality != "input":
            attrs += f' initial="{v.initial}"'
        if v.type == "Real" and v.unit:
            attrs += f' unit="{v.unit}"'
        if v.derivative_of is not None:
            attrs += f' derivative="{v.derivative_of}"'
        if v.start is not None:
            attrs += f' start="{_fmt(v.start)}"'
        body.append(f"    <{types[v.type]} {attrs}/>\n")
    body.append("  </ModelVariables>\n  <ModelStructure>\n")
    body += [f'    <Output valueReference="{v.vr}"/>\n' for v in vs if v.causality == "output"]
    body += [f'    <ContinuousStateDerivative valueReference="{v.vr}"/>\n' for v in vs if v.derivative_of is not None]
    body += [f'    <InitialUnknown valueReference="{v.vr}"/>\n' for v in vs
             if (v.causality == "output" and v.initial == "calculated") or v.derivative_of is not None]
    body += [f'    <EventIndicator valueReference="{vr["Z"] + k}"/>\n' for k in range(d.n_indicators)]
    body.append("  </ModelStructure>\n</fmiModelDescription>\n")
    return "".join(head + body)
