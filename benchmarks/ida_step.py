"""Time per internal IDA step: this library against raw scikit-sundae on the same model (issue 34).

Case: the Stribeck belt (models/belt_stribeck.toml, preset `standard`) from rest for 500 s (153
switches), rtol 1e-8, atol 1e-10. Raw: a hand-written loop over scikit-sundae's IDA on the slip
phases with a plain Python residual (benchmarks/belt_loops.py; no Jacobian, scikit-sundae's
difference quotients), stick phases in closed form. Library: :func:`hybrid.simulate` (generated
residual, analytic Jacobian, the event loop). Each is timed in one-step mode (every internal step
returned to Python: ``simulate`` without ``t_eval`` records every step) and in normal mode (only
the end of the run asked: ``t_eval=[500]``; the raw loop calls ``step(t1, "normal")`` up to each
stop). Internal steps are counted in one-step mode (the normal-mode runs take the same steps: the
final states agree to the last digit); time per step = wall time / internal steps, best of
``REPEAT``, all in one process (the ratios are from one run; the load is printed). Times are CPU
times of this process (``time.process_time``): on a shared machine wall times of runs a second
apart differ by more than the ratios measured.

Run: ``python benchmarks/ida_step.py`` (about 30 s on 2 cores).
"""

from __future__ import annotations

import os
import time

import numpy as np
from belt_loops import sundae_loop

import hybrid_models
from hybrid import simulate

T1 = 500.0
REPEAT = 5


def best(fn):
    t_best, out = np.inf, None
    for _ in range(REPEAT):
        t0 = time.process_time()
        out = fn()
        t_best = min(t_best, time.process_time() - t0)
    return t_best, out


def main() -> dict:
    system = hybrid_models.belt_stribeck()
    p = system.preset("standard")
    x0 = {"x": 0.0, "w": 0.0}
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")
    t_lib1, tr1 = best(lambda: simulate(system, p, (0.0, T1), x0))
    t_libn, trn = best(lambda: simulate(system, p, (0.0, T1), x0, t_eval=[T1]))
    t_raw1, (y1, n_raw, _, _) = best(lambda: sundae_loop(T1, one_step=True))
    t_rawn, (yn, _, _, _) = best(lambda: sundae_loop(T1, one_step=False))
    n_lib = tr1.n_steps
    assert np.array_equal(tr1.y_final, trn.y_final) and np.array_equal(y1, yn)
    rows = {
        "library, one-step (every step recorded)": (t_lib1, n_lib),
        "library, normal (t_eval=[500])": (t_libn, n_lib),
        "raw scikit-sundae, one-step": (t_raw1, n_raw),
        "raw scikit-sundae, normal": (t_rawn, n_raw),
    }
    print(f"{'run':42s} {'cpu [s]':>9s} {'steps':>7s} {'us/step':>8s}")
    for name, (t, n) in rows.items():
        print(f"{name:42s} {t:9.3f} {n:7d} {1e6 * t / n:8.1f}")
    r1 = (t_lib1 / n_lib) / (t_raw1 / n_raw)
    rn = (t_libn / n_lib) / (t_rawn / n_raw)
    print(f"per step, library / raw: one-step {r1:.2f}x, normal {rn:.2f}x (target <= 1.5x)")
    print(f"final states: library {trn.y_final}, raw {yn}; load average {os.getloadavg()[0]:.2f}")
    return {"one_step_ratio": r1, "normal_ratio": rn}


if __name__ == "__main__":
    main()
