"""The frequency response of a damper of your own, written as a network file (``tmd.toml``).

A machine (10 kg on a 40 kN/m mount) with a tuned absorber mass (1 kg on 3.6 kN/m) and a
friction contact between the two. The curve is continued over the default range around the
natural frequency of the all-stuck system, with the exact integrator; the script prints the
curve's summary and special points, writes every orbit to ``frc.csv`` and draws ``frc.png``
with the linear references (contact stuck, contact sliding) of the engine's linearisation.
"""

from pathlib import Path

import hybrid
from hybrid import Exact, SolverOptions
from hybrid.plot.frc import plot_frc

out = Path("out") / "examples" / "tmd_frequency_response"
out.mkdir(parents=True, exist_ok=True)

tmd = hybrid.load_system(Path(__file__).with_name("tmd.toml"))
params = tmd.preset("standard")
lo, hi = hybrid.continuation.frc.default_range(tmd, params)  # rad/s
fr = hybrid.frequency_response(tmd, params, (lo, hi), options=SolverOptions(method=Exact()))
print(fr)
for row in fr.special_rows:
    print(f"  {row['kind']:12s} at Omega = {row['Omega']:.6f} rad/s ({row['status']})")
peak = max(fr.rows, key=lambda r: r["amplitude_x1"])
print(f"largest max|x1| = {peak['amplitude_x1']:.6g} m at Omega = {peak['Omega']:.4f} rad/s")
with (out / "frc.csv").open("w") as fh:
    cols = list(fr.rows[0])
    fh.write(",".join(cols) + "\n")
    for r in fr.rows:
        fh.write(",".join(str(r[c]) for c in cols) + "\n")
print("wrote", plot_frc(fr, out / "frc.png"))
