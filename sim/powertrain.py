"""The turbocharged powertrain: the mean-value turbodiesel and the torque converter as components
of the mode-switching simulator, the causality check of a scenario's assembly, and the
turbocharger report (thesis chapter 4.6, section 2.4).

Components (interface of :mod:`transgen.sim.components`):

* :class:`TurbodieselSource` - the :class:`~transgen.sim.engine.TurbochargedDiesel` as the torque
  source of the mechanism's input link (the crank, flywheel and converter impeller are that
  link's inertia). States ``p_im``, ``p_em``, ``omega_tc``; ``T_in`` = engine torque.
* :class:`ConverterComponent` - the hydrodynamic converter as a resistive block between two links
  of the mechanism (pump and turbine): it drives the mechanism's named external torques
  (``torque Tp E`` and ``torque Tt L1``) with ``-T_pump`` and ``+T_turbine``. The lock-up clutch
  is a clutch of the mechanism (``clutch LU E L1``), locked and unlocked by the transmission's
  complementarity logic like every shift element; locked, the converter runs at speed ratio 1 and
  carries no torque.

Causality (thesis 2.4): :func:`causal_assembly` lists the blocks of a powertrain (engine air path:
control volumes and flow blocks; engine torque: an effort source on the input link; converter:
resistive between two links; links of the mechanism: inertial; slipping shift elements:
resistive; driveshaft: compliant; vehicle: inertial) and how they are joined;
:func:`check_powertrain` runs :func:`~transgen.sim.causality.check_connections` on it. The rigid
connections between links (gearsets, locked elements) are the algebraic loops the mode-switching
method solves inside the transmission block (thesis 2.4.3), so they are not joints here.

Report: :func:`turbo_report` summarises the turbocharger of one run (time to 90 % boost, peak turbo
speed, chi range) and compares two runs (basic vs iterative algorithm) binned by compressor mass
flow, as thesis section 4.6 discusses Figs. 4.17-4.24.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from transgen.errors import SimulationError

from .causality import AlgebraicLoopError, Block, Causality, CausalityError, check_connections
from .components import Component, Driveline, EngineOnLink, EngineWithConverter, InputTorque, LinkLoad
from .engine import EngineParams, SpeedGovernor, TurbochargedDiesel
from .maps import RPM
from .signals import Signal
from .torque_converter import TorqueConverter

__all__ = [
    "TurbodieselSource",
    "ConverterComponent",
    "turbodiesel_component",
    "converter_component",
    "causal_assembly",
    "check_powertrain",
    "check_scenario_causality",
    "TurboReport",
    "turbo_report",
    "CRANK_MODELS",
]

CRANK_MODELS = ("torque", "inertial")
"""``[input] crank_model`` of a turbodiesel: ``"torque"`` (the engine gives a torque to the input
link, which carries the crank inertia) or ``"inertial"`` (an engine model with its own crank
inertia: joined directly to the inertial input link it forms an algebraic loop and is refused)."""

def _steady_guess(p_amb: float) -> tuple[float, float, float]:
    """Generic starting point (p_im [Pa], p_em [Pa], omega_tc [rad/s]) of the steady-state solve
    (the engine's own default guess)."""
    return (1.1 * p_amb, 1.2 * p_amb, 6000.0)


_I, _K, _R = Causality.INERTIAL, Causality.COMPLIANT, Causality.RESISTIVE

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

CONVERTER_SIGNAL_UNITS = {"converter_speed_ratio": "1", "converter_torque_ratio": "1", "T_pump": "N*m",
                          "T_turbine": "N*m", "P_converter": "W"}
"""Units of the signals of :class:`ConverterComponent`."""


# ----------------------------------------------------------------------------- components


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
        return {"T_in": self.engine.torque(t, x, float(w[self.link]))}

    def power_in(self, t, x, w):
        omega = float(w[self.link])
        return self.engine.torque(t, x, omega) * omega

    def evaluate(self, t, x, w):
        omega = float(w[self.link])
        torque = self.engine.torque(t, x, omega)
        return {"T_in": torque}, self.engine.derivatives(t, x, omega), torque * omega, 0.0, 0.0

    def signals(self, t, x, w):
        omega = float(w[self.link])
        sig = self.engine.signals(t, x, omega)
        p = self.engine.params
        sig["T_in"] = sig["torque_engine"]
        sig["engine_speed_rpm"] = omega / RPM
        sig["rack"] = float(self.engine.rack(t))        # demanded (before the idle governor)
        # temperature rise and drop across the devices as the blocks see them (thesis Figs. 4.21,
        # 4.22): the temperature they receive (ambient, exhaust manifold: static) minus the one
        # they give (outlet: total for the iterative algorithm)
        sig["dT_c"] = sig["T_c_out"] - p.T_amb
        sig["dT_t"] = sig["T_em"] - sig["T_t_out"]
        return sig

    def breakpoints(self, t0=float("-inf"), t1=float("inf")):
        return self.fuel.breakpoints(t0, t1) if self.fuel is not None else ()

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


@dataclass
class ConverterComponent(Component):
    """A torque converter between two links: pump (impeller) on ``pump``, turbine on ``turbine``.

    ``converter.torques(w_pump, w_turbine)`` gives (pump torque absorbed, turbine torque
    delivered); this component applies ``-T_pump`` to the mechanism's external torque named
    ``pump_torque`` and ``+T_turbine`` to ``turbine_torque``. It dissipates
    ``T_pump*w_pump - T_turbine*w_turbine >= 0`` (the converter's efficiency ``SR*TR <= 1``).
    With the lock-up clutch between the same links locked the speed ratio is 1 and both torques
    are zero.
    """

    converter: TorqueConverter
    pump: int
    turbine: int
    pump_torque: str = "Tp"
    turbine_torque: str = "Tt"
    name: str = "converter"
    signal_units = CONVERTER_SIGNAL_UNITS

    def _torques(self, w):
        return self.converter.torques(float(w[self.pump]), float(w[self.turbine]))

    def torques(self, t, x, w):
        tp, tt = self._torques(w)
        return {self.pump_torque: -tp, self.turbine_torque: tt}

    def dissipation(self, t, x, w):
        tp, tt = self._torques(w)
        return tp * float(w[self.pump]) - tt * float(w[self.turbine])

    def evaluate(self, t, x, w):
        wp, wt = float(w[self.pump]), float(w[self.turbine])
        tp, tt = self.converter.torques(wp, wt)
        return {self.pump_torque: -tp, self.turbine_torque: tt}, [], 0.0, tp * wp - tt * wt, 0.0

    def signals(self, t, x, w):
        wp, wt = float(w[self.pump]), float(w[self.turbine])
        tp, tt = self._torques(w)
        return {"converter_speed_ratio": wt / wp if abs(wp) > 1e-9 else 0.0,
                "converter_torque_ratio": tt / tp if abs(tp) > 1e-9 else 1.0,
                "T_pump": tp, "T_turbine": tt, "P_converter": tp * wp - tt * wt}

    def causal_structure(self, link_block) -> tuple[list[Block], list[tuple[str, str]]]:
        """A resistive block between the pump and turbine links."""
        return ([Block(self.name, TorqueConverter.causality)],
                [(f"{self.name}.pump", link_block(self.pump)),
                 (f"{self.name}.turbine", link_block(self.turbine))])


# ----------------------------------------------------------------------------- scenario keys


def turbodiesel_component(r, inp: dict, keys: tuple, mech, tr) -> TurbodieselSource:
    """The ``[input] type = "turbodiesel"`` component of a scenario.

    Keys: ``turbo = "basic" | "iterative"`` (turbocharger algorithm, thesis 4.4 / 4.5),
    ``fuel_signal`` (rack: fraction of the full-load fuel, a signal; default 1), optional
    ``governor = { idle_rpm = 600, gain = 20 }`` (idle governor), ``crank_model = "torque"``
    (default) or ``"inertial"`` (refused: algebraic loop with the input link). The crank,
    flywheel and impeller inertia is the mechanism's input link.
    """
    turbo = r.text(inp, keys, "turbo", "basic")
    if turbo not in ("basic", "iterative"):
        raise r.error(keys + ("turbo",), f"turbo must be 'basic' or 'iterative', not {turbo!r}")
    fuel = r.signal(inp.get("fuel_signal", 1.0), keys + ("fuel_signal",))
    governor = None
    if "governor" in inp:
        gov = inp["governor"]
        gkeys = keys + ("governor",)
        if not isinstance(gov, dict):
            raise r.error(gkeys, "governor is a table like { idle_rpm = 600, gain = 20 }")
        for k in gov:
            if k not in ("idle_rpm", "gain"):
                raise r.error(gkeys + (k,), f"unknown key '{k}' in governor (known: gain, idle_rpm)")
        governor = SpeedGovernor(r.number(gov, gkeys, "idle_rpm", 600.0, positive=True) * RPM,
                                 r.number(gov, gkeys, "gain", 20.0, positive=True))
    crank_model = r.text(inp, keys, "crank_model", "torque")
    if crank_model not in CRANK_MODELS:
        raise r.error(keys + ("crank_model",),
                      f"crank_model must be {' or '.join(repr(c) for c in CRANK_MODELS)}, not {crank_model!r}")
    if tr.inertia[tr.link_index[mech.input]] <= 0:
        raise r.error(keys + ("type",), f"the turbodiesel drives the input link {mech.input}, which must carry the "
                                        "crank, flywheel and impeller inertia (J > 0 in the .mech file)")
    engine = TurbochargedDiesel(EngineParams(), turbo=turbo, rack=fuel.value, governor=governor)
    return TurbodieselSource(engine, tr.link_index[mech.input], fuel, crank_model)


def converter_component(r, conv: dict, keys: tuple, mech, tr) -> ConverterComponent:
    """The ``[converter]`` table of a scenario: ``pump``/``turbine`` links, ``pump_torque``/
    ``turbine_torque`` (``torque NAME LINK`` statements of the mechanism on those links),
    optional ``file`` (converter table, relative to the scenario; default the bundled one)."""
    names = {}
    for key, default in (("pump", "E"), ("turbine", "L1")):
        link = r.text(conv, keys, key, default)
        if link not in tr.link_index:
            raise r.error(keys + (key,), f"{key} link {link!r} is not a link of the mechanism "
                                         f"(links: {', '.join(tr.links)})")
        names[key] = link
    declared = {t.name: t.link for t in mech.loads}
    for key, default, link in (("pump_torque", "Tp", names["pump"]), ("turbine_torque", "Tt", names["turbine"])):
        tname = r.text(conv, keys, key, default)
        if tname not in declared:
            raise r.error(keys + (key,), f"{key} {tname!r} is not a 'torque NAME LINK' of the mechanism "
                                         f"(declared: {', '.join(declared) or 'none'}); add 'torque {tname} {link}'")
        if declared[tname] != link:
            raise r.error(keys + (key,), f"{key} {tname!r} acts on link {declared[tname]}, not on the "
                                         f"{key.split('_')[0]} link {link}")
        names[key] = tname
    if names["pump"] == names["turbine"]:
        raise r.error(keys + ("turbine",), "the pump and the turbine must be different links")
    file = r.text(conv, keys, "file", "")
    try:
        converter = TorqueConverter.load(r.source.path.parent / file) if file else TorqueConverter.load()
    except (OSError, ValueError) as exc:
        raise r.error(keys + ("file",), f"cannot load the torque converter: {exc}") from None
    return ConverterComponent(converter, tr.link_index[names["pump"]], tr.link_index[names["turbine"]],
                              names["pump_torque"], names["turbine_torque"])


# ----------------------------------------------------------------------------- causality


@dataclass
class Assembly:
    """Blocks and joints of a powertrain for :func:`~transgen.sim.causality.check_connections`;
    ``origin`` maps a block name to the scenario keys that put it there (for located errors)."""

    blocks: list[Block] = field(default_factory=list)
    joints: list[tuple[str, str]] = field(default_factory=list)
    origin: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def add(self, blocks, joints, origin: tuple[str, ...]):
        for b in blocks:
            self.blocks.append(b)
            self.origin[b.name] = origin
        self.joints.extend(joints)


def _link_block_name(name: str) -> str:
    return f"link {name}"


def causal_assembly(pt) -> Assembly:
    """The blocks of a :class:`~transgen.sim.simulate.Powertrain` and their joints.

    Mechanism links are inertial blocks (``link NAME``); each shift element is a resistive block
    on its link(s) (its causality while slipping; locked, it is a rigid connection whose loop the
    mode solution hides, thesis 2.4.3, as are the gearsets). Components: a turbodiesel's air path
    and torque (:meth:`TurbodieselSource.causal_structure`), the converter (resistive between
    two links), an input torque or engine map (an effort source, resistive), an engine with its
    own inertia behind a converter (inertial crank, resistive converter), loads (resistive), the
    driveline (compliant driveshaft and inertial vehicle). A component with a
    ``causal_structure(link_block)`` method gives its own blocks and joints.
    """
    tr = pt.transmission
    asm = Assembly()

    def link_block(i: int) -> str:
        return _link_block_name(tr.links[i])

    asm.add([Block(link_block(i), {"shaft": _I}) for i in range(len(tr.links))], [], ("mechanism",))
    for e in tr.elements:
        name = f"element {e.name}"
        if e.link2 is None:
            asm.add([Block(name, {"link1": _R})], [(f"{name}.link1", link_block(e.link1))], ("elements", e.name))
        else:
            asm.add([Block(name, {"link1": _R, "link2": _R})],
                    [(f"{name}.link1", link_block(e.link1)), (f"{name}.link2", link_block(e.link2))],
                    ("elements", e.name))
    for c in pt.components:
        if hasattr(c, "causal_structure") and callable(c.causal_structure):
            blocks, joints = c.causal_structure(link_block)
            if isinstance(c, TurbodieselSource):
                origin = ("input", "crank_model") if c.crank_model != "torque" else ("input",)
            elif isinstance(c, ConverterComponent):
                origin = ("converter",)
            else:
                origin = (getattr(c, "name", "") or type(c).__name__,)
            asm.add(blocks, joints, origin)
        elif isinstance(c, Driveline):
            asm.add([Block("driveshaft", {"a": _K, "b": _K}), Block("vehicle", {"shaft": _I})],
                    [("driveshaft.a", link_block(c.output)), ("driveshaft.b", "vehicle")], ("driveline",))
        elif isinstance(c, EngineWithConverter):
            asm.add([Block("engine", {"crank": _I}), Block("converter", TorqueConverter.causality)],
                    [("engine.crank", "converter.pump"), ("converter.turbine", link_block(c.link))], ("input",))
        elif isinstance(c, (InputTorque, EngineOnLink)):
            name = "engine" if isinstance(c, EngineOnLink) else "input torque"
            asm.add([Block(name, {"crank": _R})], [(f"{name}.crank", link_block(c.link))], ("input",))
        elif isinstance(c, LinkLoad):
            name = f"load {c.input_name}"
            keys = ("driveline",) if c.input_name == "T_out" else ("load",)
            asm.add([Block(name, {"shaft": _R})], [(f"{name}.shaft", link_block(c.link))], keys)
        # any other component: unknown causality, not checked
    return asm


def check_powertrain(pt) -> Assembly:
    """Check the causality of a powertrain's assembly before running it (thesis 2.4).

    Returns the :class:`Assembly`; raises :class:`~transgen.sim.causality.AlgebraicLoopError`
    naming both blocks of every joint of two blocks of the same kind (e.g. an inertial engine
    model on the inertial input link) or :class:`~transgen.sim.causality.CausalityError`.
    """
    asm = causal_assembly(pt)
    check_connections(asm.blocks, asm.joints)
    return asm


def check_scenario_causality(r, pt) -> Assembly:
    """:func:`check_powertrain` for a scenario being read: a refused assembly is a located
    :class:`~transgen.errors.ScenarioError` at the scenario key that put the offending block there."""
    asm = causal_assembly(pt)
    try:
        check_connections(asm.blocks, asm.joints)
    except AlgebraicLoopError as exc:
        a, b = exc.pairs[0]
        keys = next((asm.origin[n] for n in (a, b) if asm.origin.get(n, ("mechanism",)) != ("mechanism",)),
                    ("mechanism",))
        hint = ""
        if keys == ("input", "crank_model"):
            hint = ("\n  the input link already carries the crank, flywheel and impeller inertia: use "
                    "crank_model = \"torque\" (the engine then gives a torque to the link)")
        raise r.error(keys, f"invalid model assembly (thesis 2.4), refused before the run: {exc}{hint}") from None
    except CausalityError as exc:
        raise r.error(("mechanism",), f"invalid model assembly: {exc}") from None
    return asm


# ----------------------------------------------------------------------------- report


def _unique(t: np.ndarray, *ys: np.ndarray):
    """Drop the repeated times at mode changes (keep the later sample)."""
    t = np.asarray(t, dtype=float)
    keep = np.ones(len(t), dtype=bool)
    keep[:-1] = np.diff(t) > 0
    return (t[keep],) + tuple(np.asarray(y, dtype=float)[keep] for y in ys)


def _fuel_step(t: np.ndarray, rack: np.ndarray) -> float:
    """Start of the first rise of the rack by more than half of its total rise; the run's start
    if the rack never rises."""
    if len(t) == 0:
        return 0.0
    rise = float(np.max(rack) - rack[0])
    if rise <= 1e-6:
        return float(t[0])
    k = int(np.argmax(rack >= rack[0] + 0.5 * rise))
    j = k
    while j > 0 and rack[j - 1] < rack[j] - 1e-12:
        j -= 1
    return float(t[j])


def _window_end(result, t_step: float) -> float:
    """End of the boost-build window after the fuel step: the first shift (an element other than
    a lock-up clutch changing state, or its apply starting to move) after the step, else the end."""
    t_end = float(result.time[-1])
    for e in result.events:
        if e.kind != "start" and e.t > t_step + 1e-6 and any(not n.startswith("LU") for n in e.elements):
            return min(t_end, e.t)
    # shifts start when an oncoming element's apply rises
    for key, values in result.signals.items():
        if key.startswith("apply_") and not key.startswith("apply_LU"):
            t, a = _unique(result.time, values)
            rising = np.nonzero((a[1:] > a[:-1] + 1e-9) & (t[1:] > t_step + 1e-6))[0]
            if len(rising):
                t_end = min(t_end, float(t[rising[0]]))
    return t_end


@dataclass
class TurboReport:
    """Turbocharger summary of one run, and optionally its comparison with a second run.

    Times in s, speeds in rpm (``*_krpm`` in 1000 rpm), mass flows in kg/s. ``comparison``:
    ``bins`` of compressor mass flow (of the first run) with the mean turbo-speed difference
    (second - first) [krpm and %] and the mean chi difference, and the verdicts
    ``second_lower`` (turbo speed lower in every bin with flow) and ``difference_grows_with_flow``.
    """

    title: str
    fuel_step: float
    window_end: float
    boost_start: float
    boost_peak: float
    time_to_90_boost: float | None
    peak_turbo_speed_krpm: float
    peak_turbo_speed_time: float
    chi_min: float
    chi_max: float
    compressor_flow_max: float
    comparison: dict | None = None
    decoupled: dict | None = None

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def text(self) -> str:
        t90 = f"{self.time_to_90_boost:.2f} s" if self.time_to_90_boost is not None else "not reached"
        lines = [f"turbocharger: {self.title}",
                 f"  fuel step at t = {self.fuel_step:.2f} s: boost PR {self.boost_start:.2f} -> peak "
                 f"{self.boost_peak:.2f} before t = {self.window_end:.2f} s; time to 90 % boost {t90}",
                 f"  peak turbo speed {self.peak_turbo_speed_krpm:.1f} krpm at t = {self.peak_turbo_speed_time:.2f} s;"
                 f" chi {self.chi_min:.3f} .. {self.chi_max:.3f}; compressor flow up to "
                 f"{self.compressor_flow_max:.3f} kg/s"]
        c = self.comparison
        if c:
            lines.append(f"  {c['second']} vs {c['first']} (time-aligned differences, second - first, "
                         "binned by compressor mass flow of the first):")
            lines.append(f"    {'flow [kg/s]':>15} {'samples':>8} {'d turbo [krpm]':>15} {'d turbo [%]':>12} {'d chi':>9}")
            for b in c["bins"]:
                lines.append(f"    {b['flow_lo']:6.3f}-{b['flow_hi']:6.3f}  {b['samples']:8d} {b['d_turbo_krpm']:15.3f} "
                             f"{b['d_turbo_percent']:12.2f} {b['d_chi']:9.4f}")
            lines.append(f"    low flow: d turbo {c['low']['d_turbo_krpm']:.3f} krpm, d chi {c['low']['d_chi']:.4f};"
                         f" high flow: d turbo {c['high']['d_turbo_krpm']:.3f} krpm, d chi {c['high']['d_chi']:.4f}")
            lines.append(f"    {c['second']} lower: {'yes' if c['second_lower'] else 'no'}; difference grows with "
                         f"flow: {'yes' if c['difference_grows_with_flow'] else 'no'}")
        d = self.decoupled
        if d:
            lines.append(f"  iterative vs basic algorithm on the same states (decoupled from the engine's feedback; "
                         f"{d['points']} points of this run, {d['skipped']} skipped), binned by compressor mass flow:")
            lines.append(f"    {'flow [kg/s]':>15} {'points':>7} {'d chi':>9} {'d m_c [%]':>10} {'d m_t [%]':>10} "
                         f"{'M_c,in':>7} {'M_c,out':>7}")
            for b in d["bins"]:
                lines.append(f"    {b['flow_lo']:6.3f}-{b['flow_hi']:6.3f}  {b['points']:7d} {b['d_chi']:9.4f} "
                             f"{b['d_flow_c_percent']:10.2f} {b['d_flow_t_percent']:10.2f} {b['mach_c_in']:7.3f} "
                             f"{b['mach_c_out']:7.3f}")
            lines.append(f"    iterative chi lower in every bin: {'yes' if d['chi_lower'] else 'no'}; |d chi| grows with "
                         f"flow: {'yes' if d['grows_with_flow'] else 'no'}")
        return "\n".join(lines)

    __str__ = text


def _title(result) -> str:
    """A short name of a run: its scenario file's stem, else its title."""
    meta = result.meta or {}
    if meta.get("scenario"):
        return Path(str(meta["scenario"])).stem
    return str(meta.get("title") or "run")


def turbo_report(result, other=None, bins: int = 5, engine: TurbochargedDiesel | None = None) -> TurboReport:
    """Turbocharger report of a run (a :class:`~transgen.sim.result.Result` with the signals of
    :class:`TurbodieselSource`), optionally compared with a second run ``other`` (e.g. basic
    vs iterative algorithm on the same scenario).

    * time to 90 % boost: from the fuel step (start of the first rise of the rack, or the start
      of the run) to the first time the boost pressure ratio has covered 90 % of its rise to the
      peak it reaches before the first shift;
    * peak turbo speed and when; chi range; largest compressor mass flow;
    * comparison: the second run's signals are interpolated onto the first's times; the
      differences (second - first) of turbo speed and chi are averaged in ``bins`` equal-width
      bins of the first run's compressor mass flow. ``low`` and ``high`` are the lowest and
      highest bin with samples;
    * with ``engine`` (the run's :class:`TurbochargedDiesel`): :func:`algorithm_difference` along
      the run.
    """
    for key in ("omega_tc", "chi", "boost_pressure_ratio", "m_dot_c"):
        if key not in result.signals:
            raise ValueError(f"turbo_report: the result has no '{key}' signal (not a turbodiesel run)")
    rack = result.signals.get("rack", np.ones(len(result.time)))
    t, w, chi, boost, flow, rack = _unique(result.time, result["omega_tc"], result["chi"],
                                           result["boost_pressure_ratio"], result["m_dot_c"], rack)
    t_step = _fuel_step(t, rack)
    t_win = _window_end(result, t_step)
    sel = (t >= t_step) & (t <= t_win)
    if not np.any(sel):
        sel = t >= t_step
    b0 = float(np.interp(t_step, t, boost))
    b_peak = float(np.max(boost[sel]))
    t90 = None
    if b_peak > b0 + 1e-6:
        reached = np.nonzero(sel & (boost >= b0 + 0.9 * (b_peak - b0)))[0]
        if len(reached):
            t90 = float(t[reached[0]] - t_step)
    k = int(np.argmax(w))
    rep = TurboReport(_title(result), t_step, t_win, b0, b_peak, t90, float(w[k] / RPM / 1e3), float(t[k]),
                      float(np.min(chi)), float(np.max(chi)), float(np.max(flow)))
    if other is not None:
        rep.comparison = _compare(t, w, chi, flow, other, _title(result), bins)
    if engine is not None:
        rep.decoupled = algorithm_difference(result, engine, bins)
    return rep


def algorithm_difference(result, engine: TurbochargedDiesel, bins: int = 5, points: int = 400) -> dict:
    """Both turbocharger algorithms evaluated on the same states: up to ``points`` samples of
    ``result`` (intake and exhaust manifold pressures, exhaust temperature, turbo speed) are fed
    to the basic and to the iterative algorithm with the maps, shaft and port areas of
    ``engine``'s turbocharger, so the difference is the algorithm's alone, without the feedback
    through the engine that obscures it in a coupled run (the decoupling the thesis asks for in
    4.6 and 5.2).

    Returns, per bin of the basic algorithm's compressor mass flow: the mean differences
    (iterative - basic) of chi and of the compressor and turbine mass flows [%], and the mean
    compressor port Mach numbers; ``chi_lower``: iterative chi lower in every bin;
    ``grows_with_flow``: ``|d chi|`` larger in the highest bin than in the lowest. Points where
    the iterative algorithm has no solution (choked ports) are skipped and counted.
    """
    from .turbocharger import BasicTurbo, IterativeTurbo, PortAreas, TurboSolveError

    own = engine.turbo
    basic = BasicTurbo(own.compressor, own.turbine, own.shaft)
    iterative = IterativeTurbo(own.compressor, own.turbine, own.shaft, getattr(own, "ports", PortAreas()))
    p = engine.params
    t, p_im, p_em, T_em, w = _unique(result.time, result["p_im"], result["p_em"], result["T_em"], result["omega_tc"])
    rows, skipped = [], 0
    for k in np.unique(np.linspace(0, len(t) - 1, min(points, len(t))).astype(int)):
        a = basic.evaluate(p.p_amb, p.T_amb, p_im[k], p_em[k], T_em[k], p.p_amb, w[k])
        try:
            b = iterative.evaluate(p.p_amb, p.T_amb, p_im[k], p_em[k], T_em[k], p.p_amb, w[k])
        except TurboSolveError:
            skipped += 1
            continue
        if a.compressor.m_dot <= 1e-6 or a.turbine.m_dot <= 1e-6:
            continue
        rows.append((a.compressor.m_dot, b.compressor.chi - a.compressor.chi,
                     100.0 * (b.compressor.m_dot / a.compressor.m_dot - 1.0),
                     100.0 * (b.turbine.m_dot / a.turbine.m_dot - 1.0), b.mach[0], b.mach[1]))
    data = np.array(rows).reshape(-1, 6)
    flow = data[:, 0]
    out_bins = []
    if len(flow):
        edges = np.linspace(float(np.min(flow)), float(np.max(flow)), bins + 1)
        for i in range(bins):
            m = (flow >= edges[i]) & ((flow < edges[i + 1]) if i < bins - 1 else (flow <= edges[i + 1]))
            if np.any(m):
                mean = data[m].mean(axis=0)
                out_bins.append({"flow_lo": float(edges[i]), "flow_hi": float(edges[i + 1]), "points": int(np.sum(m)),
                                 "d_chi": float(mean[1]), "d_flow_c_percent": float(mean[2]),
                                 "d_flow_t_percent": float(mean[3]), "mach_c_in": float(mean[4]),
                                 "mach_c_out": float(mean[5])})
    return {"points": len(rows), "skipped": skipped, "bins": out_bins,
            "chi_lower": bool(out_bins) and all(b["d_chi"] < 0 for b in out_bins),
            "grows_with_flow": bool(out_bins) and abs(out_bins[-1]["d_chi"]) > abs(out_bins[0]["d_chi"])}


def _compare(t, w, chi, flow, other, first: str, bins: int) -> dict:
    t2, w2, chi2 = _unique(other.time, other["omega_tc"], other["chi"])
    inside = (t >= t2[0]) & (t <= t2[-1])
    t, w, chi, flow = t[inside], w[inside], chi[inside], flow[inside]
    dw = (np.interp(t, t2, w2) - w) / RPM / 1e3
    dpct = 100.0 * (np.interp(t, t2, w2) - w) / np.maximum(w, 1e-9)
    dchi = np.interp(t, t2, chi2) - chi
    edges = np.linspace(float(np.min(flow)), float(np.max(flow)), bins + 1)
    rows = []
    for i in range(bins):
        m = (flow >= edges[i]) & ((flow < edges[i + 1]) if i < bins - 1 else (flow <= edges[i + 1]))
        if not np.any(m):
            continue
        rows.append({"flow_lo": float(edges[i]), "flow_hi": float(edges[i + 1]), "samples": int(np.sum(m)),
                     "d_turbo_krpm": float(np.mean(dw[m])), "d_turbo_percent": float(np.mean(dpct[m])),
                     "d_chi": float(np.mean(dchi[m]))})
    low, high = rows[0], rows[-1]
    # "lower" judged where the flow is not negligible (the lowest bin may sit at the floor)
    flowing = rows[1:] if len(rows) > 1 else rows
    return {"first": first, "second": _title(other), "bins": rows, "low": low, "high": high,
            "second_lower": all(r["d_turbo_krpm"] < 0 for r in flowing),
            "difference_grows_with_flow": abs(high["d_turbo_krpm"]) > abs(low["d_turbo_krpm"]),
            "mean_d_turbo_krpm": float(np.mean(dw)), "mean_d_chi": float(np.mean(dchi))}
