"""Cost of 20 s of engine-only simulation at constant engine speed, for both turbo algorithms.

Run:  python benchmarks/bench_engine.py

The engine runs at 1500 rpm; the rack steps 0.2 -> 1.0 at t = 1 s and back to 0.4 at t = 10 s
(the integration is restarted at each step, as a simulator does at input discontinuities).
Integrator: scipy ``solve_ivp`` BDF, rtol 1e-6, atol (1 Pa, 1 Pa, 0.01 rad/s).

Times are CPU time of the process (``time.process_time``: steadier than the wall time on a
machine shared with other work), after one warm-up run (the compiled kernels loaded). ``us/RHS``
is one ``derivatives`` call at new arguments (no cache hit); ``us/kernel`` the compiled
evaluation alone (:func:`transgen.sim.engine.kernels.engine_evaluate`), the rest is the Python
around it (fuel, state checks, status).
"""
import time
import warnings

import numpy as np
from scipy.integrate import solve_ivp

from transgen.sim.engine import RPM, TurbochargedDiesel
from transgen.sim.engine import kernels as K

SPEED = 1500 * RPM
SEGMENTS = ((0.0, 1.0, 0.2), (1.0, 10.0, 1.0), (10.0, 20.0, 0.4))


def run(kind: str, method: str = "BDF") -> dict:
    rack = {"value": SEGMENTS[0][2]}
    eng = TurbochargedDiesel(turbo=kind, rack=lambda t: rack["value"])
    x = eng.initial_state(SPEED)
    calls = 0

    def rhs(t, y):
        nonlocal calls
        calls += 1
        return eng.derivatives(t, y, SPEED)

    start = time.process_time()
    steps = 0
    for t0, t1, r in SEGMENTS:
        rack["value"] = r
        sol = solve_ivp(rhs, (t0, t1), x, method=method, rtol=1e-6, atol=[1.0, 1.0, 1e-2])
        if not sol.success:
            raise RuntimeError(sol.message)
        x, steps = sol.y[:, -1], steps + sol.t.size - 1
    cpu = time.process_time() - start
    # cost of one right-hand side evaluation at the final state (no cache hits)
    n = 20000
    t_rhs = time.process_time()
    for i in range(n):
        eng.derivatives(20.0 + i * 1e-9, x, SPEED)
    per_call = (time.process_time() - t_rhs) / n
    evaluate, P, cdev, tdev, TB, warm = eng._kernel_inputs
    out, work, u_f = np.empty(K.N_OUT), np.empty(K.N_SOLVE), eng.fuel(20.0, SPEED)
    p_im, p_em, w_tc = map(float, x)
    t_k = time.process_time()
    for _ in range(n):
        evaluate(P, cdev, tdev, TB, warm, p_im, p_em, w_tc, SPEED, u_f, out, work)
    per_kernel = (time.process_time() - t_k) / n
    return {"cpu": cpu, "calls": calls, "steps": steps, "per_call": per_call, "per_kernel": per_kernel,
            "boost": x[0] / eng.params.p_amb, "turbo_krpm": x[2] / RPM / 1e3}


def main() -> None:
    warnings.simplefilter("ignore")
    print(f"20 s engine-only simulation at {SPEED / RPM:.0f} rpm, rack steps {SEGMENTS}")
    print(f"{'algorithm':10s} {'method':6s} {'CPU [s]':>9s} {'RHS calls':>10s} {'steps':>6s} "
          f"{'us/RHS':>8s} {'us/kernel':>10s} {'final boost PR':>15s} {'turbo [krpm]':>13s}")
    for kind in ("basic", "iterative"):
        run(kind)  # warm-up: the compiled kernels loaded from numba's cache (compiled on a first run)
        for method in ("BDF", "Radau"):
            r = run(kind, method)
            print(f"{kind:10s} {method:6s} {r['cpu']:9.3f} {r['calls']:10d} {r['steps']:6d} "
                  f"{r['per_call'] * 1e6:8.1f} {r['per_kernel'] * 1e6:10.2f} {r['boost']:15.3f} "
                  f"{r['turbo_krpm']:13.2f}")


if __name__ == "__main__":
    main()
