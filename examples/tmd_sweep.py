"""A small design sweep: the peak of the machine's amplitude against the friction level R.

One frequency response of ``tmd.toml`` per value of R (exact integrator), each reduced to its
figure of merit, the largest amplitude (half peak-to-peak) of ``x1`` over the range. Points are
written to ``out/examples/tmd_sweep/`` as they finish (a second run resumes); the script prints
the peak per R and the best R of the grid, and draws the design chart.
"""

from pathlib import Path

import hybrid
from hybrid import Exact, SolverOptions, linear_axis
from hybrid.plot.chart import write_charts

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
for _, point in sorted(res.points.items()):
    peak = f"{point['peak']:.6g} m" if point["status"] == "bounded" else "none (grows without bound)"
    print(f"R = {point['values']['R']:4.1f} N: peak of x1 {peak} ({point['status']})")
files, notes = write_charts(res, out)
for f in files:
    print("wrote", f)
