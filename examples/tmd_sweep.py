"""A small design sweep: the peak of the machine's amplitude against the friction level R.

One frequency response of ``tmd.toml`` per value of R (exact integrator), each reduced to its
figure of merit, the largest amplitude (half peak-to-peak) of ``x1`` over the range. Points are
written to ``out/examples/tmd_sweep/`` as they finish (a second run resumes); the script prints
the peak per R and the best R of the grid, and draws the design chart.
"""

from pathlib import Path

import hybrid
from hybrid import Exact, SolverOptions, linear_axis
from hybrid.plot.chart import optimum, write_charts

out = Path("out") / "examples" / "tmd_sweep"
tmd = hybrid.load_system(Path(__file__).with_name("tmd.toml"))
params = tmd.preset("standard")
res = hybrid.sweep(
    tmd,
    params,
    [linear_axis("R", 4.0, 8.0, 2.0)],  # N: 4, 6, 8
    out,
    p_range=(52.0, 60.0),  # rad/s: around the peak of x1
    coordinate="x1",
    options=SolverOptions(method=Exact()),
    resume=(out / "manifest.json").exists(),
)
WHAT = {
    "bounded": "",
    "unbounded": "none: the response grows without bound",
    "incomplete": "at least",  # parts of the range were not computed: a lower bound
}
for _, point in sorted(res.points.items()):
    status = point["status"]
    if point.get("peak") is not None:
        peak = f"{WHAT.get(status, '')} {point['peak'] * 1e3:.4g} mm at {point['peak_at']:.2f} rad/s".strip()
    else:
        peak = WHAT.get(status) or f"none ({point['message']})"
    print(f"R = {point['values']['R']:4.1f} N: peak of x1 {peak} ({status})")
best = optimum(res)
if best is None:
    print("best R: none (no point of the grid is bounded)")
else:
    print(
        f"best R: {best['values']['R']:g} N (peak of x1 {best['peak'] * 1e3:.4g} mm at {best['peak_at']:.2f} rad/s)"
    )
files, notes = write_charts(res, out)
for f in files:
    print("wrote", f)
