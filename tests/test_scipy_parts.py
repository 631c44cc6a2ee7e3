"""The simulator's default path imports only the scipy parts it uses (transgen.sim.solve.scipy_parts, a
sweep worker's start): the deferred packages are scipy's own once anything asks for more, the
LSODA solution and Brent's roots are scipy's bit for bit, and the BLAS preload is skipped only
where the environment already gives one thread."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from transgen.sim.solve import scipy_parts
from transgen.sim.solve.ode_solvers import SOLVERS, LeanLSODA, _MESSAGES


def fresh(code: str, **env: str) -> dict:
    """``code`` in a fresh interpreter (not from the checkout: see tests/test_startup.py); it
    leaves its answer in the dict ``out``, printed as JSON."""
    run = subprocess.run([sys.executable, "-c", f"import json, sys\nout = {{}}\n{code}\nprint(json.dumps(out))"],
                         capture_output=True, text=True, env=dict(os.environ, MPLBACKEND="Agg") | env,
                         cwd=tempfile.gettempdir())
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


SCIPY_LOADED = "out['loaded'] = sorted(m for m in ('scipy.integrate', 'scipy.optimize', 'scipy.linalg', " \
               "'scipy.special', 'scipy.integrate._bvp', 'scipy.integrate._ivp.ivp') if m in sys.modules)"

# a stiff-ish oscillator with a terminal event, solved by the simulator's LSODA and by scipy's solve_ivp
SOLVE = """
import numpy as np
def f(t, y):
    return np.array([y[1], -40.0 * y[0] - 0.3 * y[1] + np.sin(3 * t)])
def event(t, y):
    return y[0] + 0.02
event.terminal, event.direction = True, -1
"""


def test_the_lsoda_path_imports_no_other_scipy_package_and_gives_scipys_solution():
    answer = fresh(SOLVE + f"""
from transgen.sim.solve.ode_solvers import LeanLSODA, solve_segment
{SCIPY_LOADED}
out['deferred'] = [type(sys.modules[m]).__name__ for m in ('scipy.integrate', 'scipy.linalg')]
ours = solve_segment(f, 0.0, 5.0, np.array([0.1, 0.0]), LeanLSODA, [event], rtol=1e-8, atol=1e-10)
from scipy.integrate import LSODA, solve_ivp, quad
import scipy.integrate
out['completed'] = type(sys.modules['scipy.integrate']).__name__
out['same_class'] = scipy.integrate.LSODA is LSODA and issubclass(LeanLSODA, LSODA)
ref = solve_ivp(f, (0.0, 5.0), [0.1, 0.0], method='LSODA', events=[event], dense_output=True, rtol=1e-8, atol=1e-10)
grid = np.linspace(0.0, float(ours.t[-1]), 97)
out['same'] = (ours.t.tolist() == ref.t.tolist() and ours.y.tolist() == ref.y.tolist()
               and ours.t_events[0].tolist() == ref.t_events[0].tolist()
               and ours.sol(grid).tolist() == ref.sol(grid).tolist() and ours.message == ref.message)
out['quad'] = quad(lambda x: x * x, 0.0, 3.0)[0]
out['dir'] = sorted(dir(scipy.integrate))
import scipy.linalg
out['solve'] = scipy.linalg.solve([[2.0, 0.0], [0.0, 4.0]], [1.0, 1.0]).tolist()
out['linalg'] = type(scipy.linalg).__name__
""")
    # the packages registered, their __init__ not run (scipy.linalg: numba's BLAS check imports a submodule)
    assert answer["loaded"] == ["scipy.integrate", "scipy.linalg"]
    assert answer["deferred"][0] == "_DeferredPackage" and answer["completed"] == "module"
    import scipy

    if tuple(int(v) for v in scipy.__version__.split(".")[:2]) >= (1, 17):  # seen on 1.17; 1.10's linalg loads whole
        assert answer["deferred"][1] == "_DeferredPackage"
    assert answer["solve"] == [0.5, 0.25] and answer["linalg"] == "module"
    assert answer["same_class"] and answer["same"]
    assert answer["quad"] == pytest.approx(9.0)
    ordinary = fresh("import scipy.integrate\nout['dir'] = sorted(dir(scipy.integrate))")
    assert answer["dir"] == ordinary["dir"]  # once asked for more, the package is scipy's own


def test_scipy_sparse_stays_deferred_and_its_stand_ins_are_scipys_functions():
    """The LSODA path leaves scipy.sparse's ``__init__`` unrun: ``_ivp.common`` holds stand-ins for
    ``find`` and ``coo_matrix`` that run it and call scipy's own (a sparse numerical Jacobian
    gives scipy's result), and are replaced by scipy's own names once it has run."""
    answer = fresh("""
import numpy as np
from transgen.sim.solve.ode_solvers import LeanLSODA
common = sys.modules['scipy.integrate._ivp.common']
out['deferred'] = type(sys.modules['scipy.sparse']).__name__
out['names'] = sorted(n for n in ('find', 'coo_matrix') if n in vars(sys.modules['scipy.sparse']))
out['before'] = common.find.__module__
def f(t, y):
    return np.array([y[1] ** 2, -3.0 * y[0] + y[2], np.sin(y[2])])
y = np.array([0.3, -0.2, 0.5])
structure = np.array([[0, 1, 0], [1, 0, 1], [0, 0, 1]])
sparsity = (structure, np.array([0, 0, 1]))  # columns 0 and 1 share no row: one group
jac, _ = common.num_jac(f, 0.0, y, f(0.0, y), 1e-8, None, sparsity)
import scipy.sparse
out['after'] = [common.find is scipy.sparse.find, common.coo_matrix is scipy.sparse.coo_matrix]
out['completed'] = type(sys.modules['scipy.sparse']).__name__
reference, _ = common.num_jac(f, 0.0, y, f(0.0, y), 1e-8, None, sparsity)
out['same'] = scipy.sparse.issparse(jac) and (jac != reference).nnz == 0 and jac.format == reference.format
""")
    assert answer["deferred"] == "_DeferredPackage" and answer["names"] == []
    assert answer["before"] == "transgen.sim.solve.scipy_parts"
    assert answer["completed"] == "module" and answer["after"] == [True, True] and answer["same"]


def test_a_package_imported_already_is_used_as_it_is():
    answer = fresh("""
import scipy.integrate, scipy.optimize
from transgen.sim.solve import scipy_parts
LSODA = scipy_parts.lsoda_classes()[0]
out['same'] = LSODA is scipy.integrate.LSODA and scipy_parts.deferred_package('scipy.optimize') is scipy.optimize
out['types'] = [type(sys.modules[m]).__name__ for m in ('scipy.integrate', 'scipy.optimize')]
""")
    assert answer == {"same": True, "types": ["module", "module"]}


def test_a_deferred_package_runs_its_init_once_at_the_first_name_it_lacks():
    answer = fresh("""
from transgen.sim.solve import scipy_parts
optimize = scipy_parts.deferred_package('scipy.optimize')
import scipy.optimize._zeros  # a submodule: the package's __init__ still deferred
out['before'] = type(optimize).__name__
from scipy.optimize import brentq, least_squares
out['after'] = type(optimize).__name__
out['is_module'] = sys.modules['scipy.optimize'] is optimize and hasattr(optimize, 'minimize')
""")
    assert answer == {"before": "_DeferredPackage", "after": "module", "is_module": True}


FUNCTIONS = [lambda x: x * x - 2.0, lambda x: math.cos(x) - x, lambda x: math.exp(x) - 3.0 - x,
             lambda x: (x - 0.3) ** 3, lambda x: math.tanh(50 * (x - 0.71)) + 1e-9]


@pytest.mark.parametrize("k", range(len(FUNCTIONS)))
def test_brentq_is_scipys_bit_for_bit(k):
    from scipy.optimize import brentq as scipy_brentq

    f, eps = FUNCTIONS[k], np.finfo(float).eps
    rng = np.random.default_rng(k)
    for _ in range(20):
        a, b = float(rng.uniform(-0.5, 0.25)), float(rng.uniform(1.0, 2.0))
        if f(a) * f(b) > 0:
            continue
        for tol in (4 * eps, 1e-6):
            assert outcome(scipy_parts.brentq, f, a, b, tol) == outcome(scipy_brentq, f, a, b, tol)


def outcome(brentq, f, a, b, tol):
    """The root, or the error (a flat cubic does not converge in 100 iterations)."""
    try:
        return brentq(f, a, b, xtol=tol, rtol=4 * np.finfo(float).eps)
    except (RuntimeError, ValueError) as exc:
        return type(exc), str(exc)


def test_brentq_refuses_nan_and_an_interval_without_a_sign_change():
    with pytest.raises(ValueError, match="NaN"):
        scipy_parts.brentq(lambda x: math.nan if x > 0.5 else -1.0, 0.0, 1.0, xtol=1e-12, rtol=1e-15)
    with pytest.raises(ValueError):
        scipy_parts.brentq(lambda x: x * x + 1.0, 0.0, 1.0, xtol=1e-12, rtol=1e-15)


def test_solvers_and_the_stiff_solvers_at_first_use():
    from transgen.sim.solve import ode_solvers
    from transgen.sim.solve.ode_stiff import LeanBDF, LeanRadau

    assert SOLVERS["LSODA"] is LeanLSODA and SOLVERS["BDF"] is LeanBDF and SOLVERS.get("Radau") is LeanRadau
    assert "BDF" in SOLVERS and SOLVERS.get("RK45", "RK45") == "RK45" and ode_solvers.LeanBDF is LeanBDF
    with pytest.raises(KeyError):
        SOLVERS["RK45"]


def test_blas_preload_is_skipped_only_where_the_environment_gives_one_thread():
    probe = "from transgen.blas import single_threaded\nwith single_threaded('scipy.linalg'):\n    pass\n" \
            "out['linalg'] = 'scipy.linalg' in sys.modules"
    assert fresh(probe, OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1") == {"linalg": False}
    assert fresh(probe, OPENBLAS_NUM_THREADS="2", MKL_NUM_THREADS="1") == {"linalg": True}


# --- the public fallback (TRANSGEN_SCIPY_PUBLIC=1, or a private name that fails to import) ---

RUN = """
import numpy as np
from transgen.sim import load_scenario
from transgen.sim.solve import ode_solvers, scipy_parts
out['public'] = scipy_parts.PUBLIC
out['lean'] = scipy_parts.lsoda_routine() is not None
out['bdf'] = ode_solvers.SOLVERS['BDF'].__module__
for name, method in RUNS:
    result = load_scenario(name, overrides={'simulation.method': method}).run()
    out[f'{name}/{method}'] = {'success': bool(result.success),
                               'events': [(e.t, e.kind, list(e.elements)) for e in result.events],
                               'end': {k: float(v[-1]) for k, v in sorted(result.signals.items())}}
"""
RUNS = [("simple2_upshift", "LSODA"), ("simple2_upshift", "BDF"), ("simple2_upshift", "Radau"),
        ("ht740_improved", "LSODA")]


def _agree(a: dict, b: dict, rtol: float = 1e-5) -> None:
    for key in (f"{name}/{method}" for name, method in RUNS):
        x, y = a[key], b[key]
        assert x["success"] and y["success"], key
        assert [(k, el) for _, k, el in x["events"]] == [(k, el) for _, k, el in y["events"]], key
        np.testing.assert_allclose([t for t, _, _ in x["events"]], [t for t, _, _ in y["events"]], rtol=0, atol=1e-6)
        assert x["end"].keys() == y["end"].keys()
        for name in x["end"]:
            assert x["end"][name] == pytest.approx(y["end"][name], rel=rtol, abs=1e-6), (key, name)


@pytest.fixture(scope="module")
def private_runs():
    answer = fresh(f"RUNS = {RUNS!r}\n" + RUN, TRANSGEN_SCIPY_PUBLIC="0")
    assert not answer["public"] and answer["bdf"] == "transgen.sim.solve.ode_stiff"
    return answer


def test_the_public_fallback_gives_the_same_runs(private_runs):
    """TRANSGEN_SCIPY_PUBLIC=1: scipy's public LSODA/BDF/Radau with their own steps, scipy's brentq."""
    public = fresh(f"RUNS = {RUNS!r}\n" + RUN, TRANSGEN_SCIPY_PUBLIC="1")
    assert public["public"] and not public["lean"] and public["bdf"].startswith("scipy.integrate")
    _agree(private_runs, public)


def test_a_private_name_that_fails_to_import_falls_back_to_the_public_api(private_runs):
    """Each private module made unimportable (as a scipy release that renames it would): the run
    still completes, on the public classes, with the same events and end states."""
    block = """
import sys, types, scipy.integrate, scipy.optimize
del scipy.integrate._odepack
sys.modules['scipy.integrate._odepack'] = sys.modules['scipy.optimize._zeros'] = None
for m in ('bdf', 'radau', 'lsoda', 'base', 'common'):  # the modules without the private names
    sys.modules['scipy.integrate._ivp.' + m] = types.ModuleType(m)
"""
    broken = fresh(block + f"RUNS = {RUNS!r}\n" + RUN, TRANSGEN_SCIPY_PUBLIC="0")
    assert not broken["public"] and not broken["lean"] and broken["bdf"].startswith("scipy.integrate")
    _agree(private_runs, broken)


def test_brentq_falls_back_to_scipys_where_the_routine_misbehaves(monkeypatch):
    """A compiled routine that answers wrongly on the check root is not used."""
    from scipy.optimize import brentq as scipy_brentq

    class Wrong:
        @staticmethod
        def _brentq(*args):
            return 1.0

    monkeypatch.setattr(scipy_parts, "_deferred_import", lambda packages, load: Wrong)
    assert scipy_parts._load_brentq() is scipy_brentq
    monkeypatch.setattr(scipy_parts, "PUBLIC", True)
    assert scipy_parts._load_brentq() is scipy_brentq


def test_the_messages_are_solve_ivps():
    from scipy.integrate import solve_ivp

    def stop(t, y):
        return y[0] - 0.5

    stop.terminal = True
    done = solve_ivp(lambda t, y: [1.0], (0.0, 1.0), [0.0])
    hit = solve_ivp(lambda t, y: [1.0], (0.0, 1.0), [0.0], events=[stop])
    assert (done.status, done.message) == (0, _MESSAGES[0]) and (hit.status, hit.message) == (1, _MESSAGES[1])
