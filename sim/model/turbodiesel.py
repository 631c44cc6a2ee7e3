"""The mean-value turbodiesel as a component of the mode-switching simulator (thesis chapter 4.6),
and the scenario keys that make it.

:class:`TurbodieselSource` - the :class:`~transgen.sim.engine.TurbochargedDiesel` as the torque
source of the mechanism's input link (the crank, flywheel and converter impeller are that link's
inertia; interface of :mod:`transgen.sim.model.components`). States ``p_im``, ``p_em``,
``omega_tc``; ``T_in`` = engine torque. :func:`turbodiesel_component` reads ``[input] type =
"turbodiesel"``. A module of its own, apart from the converter (:mod:`.powertrain`): a run without
the turbodiesel does not import it, its maps and their TOML reader. The turbocharger report of a
run is :mod:`transgen.sim.engine.turbo_report`.
"""
from __future__ import annotations

import inspect
from dataclasses import fields, replace
from functools import lru_cache
from types import SimpleNamespace

import numpy as np

from transgen.errors import SimulationError

from ..core.causality import Block, Causality
from .components import Component
from ..engine.diesel import EngineParams, SpeedGovernor, TurbochargedDiesel
from ..engine.gas import AIR, EXHAUST, RPM, Gas
from ..engine.map_file import DATA_DIR, CompressorMap, MapError, TurbineMap, parse_map
from ..engine.turbocharger import BasicTurbo, IterativeTurbo, PortAreas, TurboShaft
from ..core.signals import Signal

__all__ = [
    "TurbodieselSource",
    "turbodiesel_component",
    "CRANK_MODELS",
    "GOVERNOR_KEYS",
    "ENGINE_KEYS",
    "SHAFT_KEYS",
    "PORT_KEYS",
    "GAS_KEYS",
    "SOLVER_KEYS",
    "turbodiesel_defaults",
]

CRANK_MODELS = ("torque", "inertial")
"""``[input] crank_model`` of a turbodiesel: ``"torque"`` (the engine gives a torque to the input
link, which carries the crank inertia) or ``"inertial"`` (an engine model with its own crank
inertia: joined directly to the inertial input link it forms an algebraic loop and is refused)."""


def _steady_guess(p_amb: float) -> tuple[float, float, float]:
    """Generic starting point (p_im [Pa], p_em [Pa], omega_tc [rad/s]) of the steady-state solve
    (the engine's own default guess)."""
    return (1.1 * p_amb, 1.2 * p_amb, 6000.0)


_I, _R = Causality.INERTIAL, Causality.RESISTIVE

ENGINE_SIGNAL_UNITS = {
    "p_im": "Pa", "p_em": "Pa", "boost_pressure_ratio": "1", "turbo_speed": "rad/s",
    "turbo_speed_rpm": "rpm", "engine_speed": "rad/s", "engine_speed_rpm": "rpm",
    "fuel_per_cycle": "kg", "lambda": "1", "T_em": "K", "T_e": "K", "residual_gas_fraction": "1",
    "power_engine": "W", "eta_vol": "1", "m_dot_air_cyl": "kg/s", "m_dot_fuel": "kg/s",
    "torque_engine": "N*m", "omega_tc": "rad/s", "omega_tc_dot": "rad/s^2", "m_dot_c": "kg/s",
    "m_dot_t": "kg/s", "T_c_out": "K", "T_t_out": "K", "torque_c": "N*m", "torque_t": "N*m",
    "torque_tc_damping": "N*m", "power_c": "W", "power_t": "W", "chi": "1", "PR_c": "1",
    "ER_t": "1", "eta_c": "1", "eta_t": "1", "N_corr_c": "rad/s", "N_corr_t": "rad/s",
    "mach_c_in": "1", "mach_c_out": "1", "mach_t_in": "1", "mach_t_out": "1", "rack": "1",
    "dT_c": "K", "dT_t": "K", "T_in": "N*m",
}
"""Units of the signals of :class:`TurbodieselSource` (SI)."""


def _squared(x):
    """``x ** 2`` for a number, and for each number of an array (C ``pow``, as Python computes it:
    numpy's square rounds differently in about one case in a thousand)."""
    return np.array([v ** 2 for v in x.tolist()]) if isinstance(x, np.ndarray) else x ** 2


class TurbodieselSource(Component):
    """The mean-value turbodiesel driving the mechanism's input link.

    Parameters
    ----------
    engine : TurbochargedDiesel
        The engine (its rack is the fuel signal; see :func:`turbodiesel_component`).
    link : int
        Index of the input link (crank + flywheel + converter impeller) in the link-speed array.
    fuel : Signal, optional
        The rack signal, for its breakpoints and the ``rack`` output signal.
    crank_model : {"torque", "inertial"}
        See :data:`CRANK_MODELS`; only ``"torque"`` runs (``"inertial"`` is refused by the
        causality check).
    name : str

    Notes
    -----
    ``torques`` gives ``{"T_in": engine torque}``; ``power_in`` is that torque times the link
    speed (the engine's work is the work into the mechanism); the engine's own states store no
    mechanical energy of the mechanism, so ``energy`` and ``dissipation`` are zero. A NaN or
    infinity in the engine raises :class:`~transgen.sim.engine.NonFiniteError` naming the part of
    the engine, the time and the state; the simulator stops the run with that message.
    """

    state_names = TurbochargedDiesel.state_names
    signal_units = ENGINE_SIGNAL_UNITS

    def __init__(self, engine: TurbochargedDiesel, link: int, fuel: Signal | None = None,
                 crank_model: str = "torque", name: str = "engine"):
        if crank_model not in CRANK_MODELS:
            raise ValueError(f"crank_model must be one of {', '.join(CRANK_MODELS)}, not {crank_model!r}")
        self.engine = engine
        self.link = link
        self.fuel = fuel
        self.crank_model = crank_model
        self.name = name
        self.request = None  # a shift's torque-request factor [-], folded into ``fuel`` (scenario._attach_request)

    def initial_state(self, w):
        """Steady state at the initial link speed and the fuel of t = 0 (a Newton solve from a
        generic guess first; the engine's own pseudo-transient search if that fails)."""
        omega = float(w[self.link])
        eng = self.engine
        if abs(omega) >= eng.params.firing_speed:
            pa = eng.params.p_amb
            try:
                return np.array(eng.steady_state(omega, eng.fuel(0.0, omega), guess=_steady_guess(pa)).state)
            except SimulationError:
                pass
        return np.asarray(eng.initial_state(omega), dtype=float)

    def derivatives(self, t, x, w):
        return self.engine.derivatives(t, x, float(w[self.link]))

    def torques(self, t, x, w):
        return {"T_in": self.engine.crank_torque(t, x, float(w[self.link]))}

    def power_in(self, t, x, w):
        omega = float(w[self.link])
        return self.engine.torque(t, x, omega) * omega

    def evaluate(self, t, x, w):
        omega = float(w[self.link])
        torque, derivatives = self.engine.torque_and_derivatives(t, x, omega)
        return {"T_in": torque}, derivatives, torque * omega, 0.0, 0.0

    def signals(self, t, x, w):
        omega = float(w[self.link])
        return self._signals(self.engine.signals(t, x, omega), omega, float(self.engine.rack(t)),
                             None if self.request is None else float(self.request.value(t)))

    def _signals(self, sig: dict, omega, rack, request) -> dict:
        """The engine's signals ``sig`` with this component's own, at the engine speed ``omega``
        [rad/s], the demanded ``rack`` and the torque ``request`` (numbers, or arrays over times)."""
        p = self.engine.params
        sig["T_in"] = sig["torque_engine"]
        sig["engine_speed_rpm"] = omega / RPM
        sig["rack"] = rack        # demanded (before the idle governor)
        if request is not None:
            sig["torque_request"] = request
        # temperature rise and drop across the devices, total to total (thesis Figs. 4.21, 4.22):
        # the outlet temperatures are totals; the inlet states (ambient, exhaust manifold) are
        # static at the ports, made total with the port Mach number (eq. 4.34; 0 for the basic
        # algorithm, where static and total coincide)
        T0_c_in = p.T_amb * (1.0 + 0.5 * (AIR.gamma - 1.0) * _squared(sig.get("mach_c_in", 0.0)))
        T0_t_in = sig["T_em"] * (1.0 + 0.5 * (EXHAUST.gamma - 1.0) * _squared(sig.get("mach_t_in", 0.0)))
        sig["dT_c"] = sig["T_c_out"] - T0_c_in
        sig["dT_t"] = T0_t_in - sig["T_t_out"]
        return sig

    def sample(self, ts, X, W):
        """The signals at the output times (:meth:`signals`, one engine evaluation each, computed
        over all times at once); the torque is the signal ``T_in`` and the engine stores no
        energy of the mechanism."""
        if not len(ts):
            return {}, {}, np.zeros(0)
        omega = np.asarray(W[self.link], dtype=float)
        rack = np.array([float(self.engine.rack(t)) for t in ts])
        request = None if self.request is None else np.array([float(self.request.value(t)) for t in ts])
        signals = self._signals(self.engine.sample(ts, X, omega), omega, rack, request)
        return {"T_in": signals["T_in"]}, signals, np.zeros(len(ts))

    def breakpoints(self, t0=float("-inf"), t1=float("inf")):
        return self.fuel.breakpoints(t0, t1) if self.fuel is not None else ()

    @property
    def causal_keys(self) -> tuple[str, ...]:
        """The scenario keys a causality error names (:mod:`.assembly`): ``[input]``, and its
        ``crank_model`` where that is not the torque model."""
        return ("input", "crank_model") if self.crank_model != "torque" else ("input",)

    def causal_structure(self, link_block) -> tuple[list[Block], list[tuple[str, str]]]:
        """Blocks and joints: the engine's air path (control volumes and flow blocks, thesis
        2.4.6), its torque model as the block ``engine`` (port ``crank``: resistive, an effort
        source; inertial with ``crank_model = "inertial"``) on the input link."""
        blocks, joints = self.engine.causal_structure()
        rename = {"cylinders": self.name, "crank": link_block(self.link)}
        out = []
        for b in blocks:
            if b.name == "crank":
                continue  # the crank is the mechanism's input link
            if b.name == "cylinders":
                kinds = dict(b.ports)
                kinds["crank"] = _I if self.crank_model == "inertial" else _R
                b = Block(self.name, kinds)
            out.append(b)

        def fix(ep):
            name, dot, port = ep.partition(".")
            name = rename.get(name, name)
            return name + (dot + port if name != link_block(self.link) else "")

        return out, [(fix(a), fix(b)) for a, b in joints]



# ----------------------------------------------------------------------------- scenario keys

GOVERNOR_KEYS = frozenset({"idle_rpm", "gain"})
"""Keys of ``[input] governor = {...}``: the idle governor (:class:`SpeedGovernor`)."""
ENGINE_KEYS = frozenset(f.name for f in fields(EngineParams) if f.name not in ("air", "exhaust", "shaft"))
"""Keys of ``[input] engine = {...}``: the fields of :class:`~transgen.sim.engine.EngineParams`
(SI units, as documented there) that are numbers or lists of numbers."""
SHAFT_KEYS = frozenset(f.name for f in fields(TurboShaft))
"""Keys of ``[input] shaft = {...}``: turbo rotor inertia and damping (:class:`TurboShaft`)."""
PORT_KEYS = frozenset(f.name for f in fields(PortAreas))
"""Keys of ``[input] ports = {...}``: duct areas [m^2] of the iterative algorithm (:class:`PortAreas`)."""
GAS_KEYS = frozenset(f.name for f in fields(Gas))
"""Keys of ``[input] air = {...}`` and ``exhaust = {...}``: the gases (:class:`Gas`, J/(kg*K))."""
_SOLVER = {k: v.default for k, v in inspect.signature(IterativeTurbo).parameters.items()
           if isinstance(v.default, (int, float)) and not isinstance(v.default, bool)}
SOLVER_KEYS = frozenset(_SOLVER)
"""Keys of ``[input] turbo_solver = {...}``: the iterative algorithm's mass-flow and temperature
solves (:class:`IterativeTurbo`: ``xtol`` [kg/s], ``maxiter``, ``inner_tol``, ``inner_maxiter``)."""

def turbodiesel_defaults() -> dict[str, object]:
    """``"engine.NAME"``, ``"shaft.NAME"``, ``"ports.NAME"`` -> the default value of every key of
    the turbodiesel's sub-tables (lists for tuples), the values a scenario gets without them."""
    out: dict[str, object] = {}
    defaults = EngineParams()
    for table, keys, obj in (("engine", ENGINE_KEYS, defaults), ("shaft", SHAFT_KEYS, defaults.shaft),
                             ("ports", PORT_KEYS, PortAreas()), ("air", GAS_KEYS, defaults.air),
                             ("exhaust", GAS_KEYS, defaults.exhaust), ("turbo_solver", SOLVER_KEYS, SimpleNamespace(**_SOLVER))):
        for name in sorted(keys):
            value = getattr(obj, name)
            out[f"{table}.{name}"] = list(value) if isinstance(value, tuple) else value
    return out


_SIGNED = frozenset({"c_vol", "c_fric"})  # polynomial coefficients: any sign
_NON_NEGATIVE = frozenset({"x_cv", "h_tot", "firing_speed", "full_load_fuel", "full_load_speed", "c1", "c2"})


def _parameters(r, table: dict, keys: tuple, defaults) -> dict:
    """The values of ``table`` (keys of the dataclass instance ``defaults``) with the type of each
    default: whole numbers >= 1 for ints, lists of numbers (of the same length where the default
    has a fixed length) for tuples, positive numbers for floats (>= 0 or any sign where the
    parameter allows)."""
    out = {}
    for name in table:
        default = getattr(defaults, name)
        if isinstance(default, tuple):
            fixed = name in _SIGNED
            values = r.numbers(table, keys, name, len(default) if fixed else None)
            if name not in _SIGNED and min(values) < 0:
                raise r.error(keys + (name,), f"'{name}' must be numbers >= 0")
            out[name] = tuple(values)
        elif isinstance(default, int):
            v = table[name]
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise r.error(keys + (name,), f"'{name}' must be a whole number >= 1, not {v!r}")
            out[name] = v
        else:
            out[name] = r.number(table, keys, name, minimum=0.0 if name in _NON_NEGATIVE else None,
                                 positive=name not in _NON_NEGATIVE)
    return out


def _engine_params(r, inp: dict, keys: tuple) -> EngineParams:
    """``EngineParams`` with the ``engine``, ``shaft``, ``air`` and ``exhaust`` tables of ``[input]``
    over the defaults."""
    ekeys = keys + ("engine",)
    defaults = EngineParams()
    values = _parameters(r, r.subtable(inp, keys, "engine", ENGINE_KEYS), ekeys, defaults)

    def part(name, allowed, default):
        given = _parameters(r, r.subtable(inp, keys, name, allowed), keys + (name,), default)
        return replace(default, **given) if given else default

    shaft = part("shaft", SHAFT_KEYS, defaults.shaft)
    for name in ("air", "exhaust"):
        gas = values[name] = part(name, GAS_KEYS, getattr(defaults, name))
        if gas.cp <= gas.R:
            raise r.error(keys + (name,), f"{name}: cp ({gas.cp:g}) must exceed R ({gas.R:g}) J/(kg*K)")
    speeds, fuel = values.get("full_load_speed", defaults.full_load_speed), values.get("full_load_fuel", defaults.full_load_fuel)
    if len(speeds) != len(fuel):
        raise r.error(ekeys, f"full_load_speed and full_load_fuel must have as many entries ({len(speeds)} and {len(fuel)})")
    if any(b <= a for a, b in zip(speeds, speeds[1:])):
        raise r.error(ekeys + ("full_load_speed",), "full_load_speed must be increasing [rad/s]")
    return replace(defaults, shaft=shaft, **values)


@lru_cache(maxsize=32)
def _map(text: str, path: str) -> CompressorMap | TurbineMap:
    return parse_map(text, path)


def _device(r, inp: dict, keys: tuple, name: str, default: str, kind: type, gas: Gas):
    """The compressor or turbine of the map file ``[input] name`` (default: the shipped map),
    working on ``gas``."""
    from ..engine.compressor import Compressor
    from ..engine.preprocessor import preprocess_compressor, preprocess_turbine
    from ..engine.turbine import Turbine

    key = keys + (name,)
    path = r.data_path(key, r.text(inp, keys, name)) if name in inp else DATA_DIR / default
    try:
        cmap = _map(r.read_text(key, path, "map file"), str(path))
        if not isinstance(cmap, kind):
            raise MapError(f"{path} is a {'compressor' if isinstance(cmap, CompressorMap) else 'turbine'} map, "
                           f"not a {'compressor' if kind is CompressorMap else 'turbine'} map")
        if kind is CompressorMap:
            return Compressor(preprocess_compressor(cmap), gas)
        return Turbine(preprocess_turbine(cmap), gas)
    except MapError as exc:
        raise r.error(key, f"bad {name}: {exc}") from None


def turbodiesel_component(r, inp: dict, keys: tuple, mech, tr) -> TurbodieselSource:
    """The ``[input] type = "turbodiesel"`` component of a scenario.

    Keys: ``turbo = "basic" | "iterative"`` (turbocharger algorithm, thesis 4.4 / 4.5),
    ``fuel_signal`` (rack: fraction of the full-load fuel, a signal; default 1), optional
    ``governor = { idle_rpm = 600, gain = 20 }`` (idle governor), ``crank_model = "torque"``
    (default) or ``"inertial"`` (refused: algebraic loop with the input link); the tables
    ``engine`` (:data:`ENGINE_KEYS`), ``shaft`` (:data:`SHAFT_KEYS`) and ``ports``
    (:data:`PORT_KEYS`, iterative algorithm only) over the defaults of those classes;
    ``compressor_map``, ``turbine_map`` (map files; default the shipped W&E maps). The crank,
    flywheel and impeller inertia is the mechanism's input link.
    """
    turbo = r.text(inp, keys, "turbo", "basic")
    if turbo not in ("basic", "iterative"):
        raise r.error(keys + ("turbo",), f"turbo must be 'basic' or 'iterative', not {turbo!r}")
    fuel = r.signal(inp.get("fuel_signal", 1.0), keys + ("fuel_signal",))
    governor = None
    if "governor" in inp:
        gkeys = keys + ("governor",)
        if not isinstance(inp["governor"], dict):
            raise r.error(gkeys, "governor is a table like { idle_rpm = 600, gain = 20 }")
        gov = r.subtable(inp, keys, "governor", GOVERNOR_KEYS)
        governor = SpeedGovernor(r.number(gov, gkeys, "idle_rpm", 600.0, positive=True) * RPM,
                                 r.number(gov, gkeys, "gain", 20.0, positive=True))
    crank_model = r.text(inp, keys, "crank_model", "torque")
    if crank_model not in CRANK_MODELS:
        raise r.error(keys + ("crank_model",),
                      f"crank_model must be {' or '.join(repr(c) for c in CRANK_MODELS)}, not {crank_model!r}")
    if tr.inertia[tr.link_index[mech.input]] <= 0:
        raise r.error(keys + ("type",), f"the turbodiesel drives the input link {mech.input}, which must carry the "
                                        "crank, flywheel and impeller inertia (J > 0 in the .mech file)")
    params = _engine_params(r, inp, keys)
    ports = r.subtable(inp, keys, "ports", PORT_KEYS)
    solver = r.subtable(inp, keys, "turbo_solver", SOLVER_KEYS)
    for name, given in (("ports", ports), ("turbo_solver", solver)):
        if given and turbo != "iterative":
            raise r.error(keys + (name,), f"{name} is used by the iterative turbo algorithm only (turbo = \"iterative\")")
    devices = (_device(r, inp, keys, "compressor_map", "we_compressor.toml", CompressorMap, params.air),
               _device(r, inp, keys, "turbine_map", "we_turbine.toml", TurbineMap, params.exhaust))
    if turbo == "iterative":
        charger = IterativeTurbo(*devices, params.shaft, PortAreas(**_parameters(r, ports, keys + ("ports",), PortAreas())),
                                 **_parameters(r, solver, keys + ("turbo_solver",), SimpleNamespace(**_SOLVER)))
    else:
        charger = BasicTurbo(*devices, params.shaft)
    engine = TurbochargedDiesel(params, turbo=charger, rack=fuel.value, governor=governor)
    return TurbodieselSource(engine, tr.link_index[mech.input], fuel, crank_model)
