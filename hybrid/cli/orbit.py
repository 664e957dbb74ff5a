"""``hybrid orbit``: the periodic orbit at one parameter set, with its Floquet multipliers."""

from __future__ import annotations

import time

from ..continuation.periodic import periodic_orbit
from ..core.budget import time_limit
from ..core.options import ShootingOptions
from ..core.plain import options_text
from ..engine.io import to_json, write_trajectory_csv
from ..orbits.orbit import PeriodicOrbit, stability_text
from .common import (
    OUT_HELP,
    add_budget,
    add_guess_args,
    add_model_args,
    add_tolerances,
    announce,
    check_integrator,
    guess,
    info,
    model,
    nonnegative_int,
    output_dir,
    parameters,
    positive_int,
    results,
    samples_per_period,
    solver_options,
    unit,
)

#: The files `orbit` writes in its output folder.
FILES = ("orbit.csv", "orbit.png", "orbit.json")


def register(sub) -> None:
    """Add this subcommand to the subparsers of ``hybrid``."""
    p = sub.add_parser("orbit", help="periodic orbit at one forcing frequency, with its Floquet multipliers")
    add_model_args(p)
    add_guess_args(p)
    p.add_argument(
        "--transient",
        type=nonnegative_int,
        default=10,
        metavar="N",
        help="forcing periods simulated from the guess before Newton's method (default 10); if Newton "
        "fails from there, the orbit is sought by continuation in the forcing frequency (0: no fallback)",
    )
    p.add_argument(
        "--subharmonic",
        type=positive_int,
        default=1,
        metavar="N",
        help="seek an orbit of N forcing periods (a subharmonic; default 1), its multipliers those of the "
        "map over N periods",
    )
    add_tolerances(p)
    p.add_argument(
        "--samples-per-period",
        type=positive_int,
        default=512,
        help="samples of the period (default 512, at most 100000)",
    )
    p.add_argument("--out", default=None, help=OUT_HELP)
    p.add_argument("--json", action="store_true", help="print the orbit as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")
    add_budget(p)
    p.set_defaults(handler=cmd_orbit)


def orbit_text(orbit: PeriodicOrbit, preset: str | None) -> str:
    """A readable summary of a periodic orbit (the stdout of ``hybrid orbit`` without ``--json``)."""
    system = orbit.system
    omega = orbit.params.get("Omega")
    head = f"{system.name}" + (f", preset `{preset}`" if preset else "")
    head += (f", Omega = {omega:g} rad/s" if omega is not None else "") + f": period T = {orbit.period:.9g} s"
    head += " (autonomous: the period is an unknown, found with the orbit)" if system.period is None else ""
    head += f" ({orbit.periods} forcing periods: a subharmonic orbit)" if orbit.periods > 1 else ""
    lines = [
        head,
        f"  computed with options={options_text(orbit.options)}, settings={options_text(orbit.settings)}",
    ]
    if not orbit.converged:
        lines.append(f"  NO periodic orbit: {orbit.message}")
        return "\n".join(lines)
    lines.append(
        f"  converged: residual {orbit.residual:.2g} after {orbit.iterations} Newton iterations, "
        f"cond(I - M) = {orbit.condition:.3g}"
    )
    route = {"newton": "Newton's method from the guess (after its transient)"}.get(orbit.route, orbit.route)
    lines.append(f"  found by: {route}")
    lines.append(f"  stability: {stability_text(orbit)}")
    seq = " -> ".join(orbit.mode_sequence)
    lines.append(
        f"  {orbit.transitions_per_period} switches per period; modes from t0 = {orbit.t0:.6g} s: {seq}"
    )
    if orbit.mode_fractions:
        fr = ", ".join(f"{m} {f:.4f}" for m, f in orbit.mode_fractions.items())
        lines.append(f"  fraction of the period per mode: {fr}")
    lines.append("  multipliers (Re, Im, |mu|, kind):")
    for mu, kind in zip(orbit.multipliers, orbit.multiplier_kinds, strict=True):
        lines.append(f"    {mu.real:+.9f} {mu.imag:+.9f}i   |mu| = {abs(mu):.9f}   {kind}")
    lines.append("  amplitudes (max |x| and half peak-to-peak over the period):")
    width = max(len(n) for n in orbit.amplitude)
    for name, amp in orbit.amplitude.items():
        u = unit(system, name)
        lines.append(
            f"    {name:{width}s}  {amp:.9g}  {orbit.half_peak_to_peak[name]:.9g}" + (f" {u}" if u else "")
        )
    k = orbit.attractor_periods
    if k is not None and ((k > 1 and orbit.periods % k) or (k == 0 and not orbit.stable)):
        lines.append(
            f"  the transient settled on an orbit of {orbit.attractor_periods} forcing periods"
            if orbit.attractor_periods
            else "  the transient repeated after none of 1 to 8 forcing periods (not settled, or not periodic)"
        )
    lines.append(f"  {orbit.message}")
    return "\n".join(lines)


def cmd_orbit(args) -> int:
    system = model(args.model)
    spp = samples_per_period(args)
    preset, params = parameters(system, args)
    x0, mode0 = guess(system, args)
    options = solver_options(args)
    check_integrator(system, params, options)
    out = output_dir(system, args)
    with results(out, FILES) as files:
        announce(system, preset, params)  # (after the folder is locked and checked)
        t0 = time.perf_counter()
        with time_limit(args.max_time):
            orbit = periodic_orbit(
                system,
                params,
                x0,
                mode0,
                options=options,
                settings=ShootingOptions(
                    transient_periods=args.transient, samples_per_period=spp, periods=args.subharmonic
                ),
            )
        wall = time.perf_counter() - t0
        summary = {"omega": params.get("Omega"), "preset": preset, **orbit.to_dict()}
        summary["multiplier_moduli"] = [float(abs(z)) for z in orbit.multipliers]
        summary["wall_time_s"] = wall
        written: list[str] = []
        if orbit.converged:  # (else the folder keeps no orbit: a previous run's files are removed)
            write_trajectory_csv(orbit.trajectory, files.path("orbit.csv"))
            written.append("orbit.csv")
            if not args.no_plot:
                from ..plot.trajectory import plot_orbit  # matplotlib only when a figure is wanted

                plot_orbit(orbit, files.path("orbit.png"))
                written.append("orbit.png")
            written.append("orbit.json")
            summary["files"] = [str(files.final(n)) for n in written]
            files.path("orbit.json").write_text(to_json(summary) + "\n")
    print(to_json(summary) if args.json else orbit_text(orbit, preset))
    for n in written:
        info(f"wrote {out / n}")
    if not orbit.converged:
        info(f"hybrid: no periodic orbit: {orbit.message}")
        return 1
    info(f"periodic orbit in {wall:.2f} s")
    return 0
