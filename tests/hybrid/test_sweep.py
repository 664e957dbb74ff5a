"""Parameter sweeps (issue 10): grid, figure of merit against the closed form, executors
(processes, Dask), failures recorded, resume (also after SIGKILL), charts, and the CLI's errors.

The model is the forced linear oscillator ``m x'' + c x' + k x = F sin(Omega t)`` of
``problems.forced_oscillator``: its steady amplitude is ``|F / (k - m Omega^2 + i c Omega)|``
at every frequency, so each point's curve is checked against that closed form.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from problems import forced_oscillator

import hybrid
from hybrid.cli import main
from hybrid.plot.chart import chart_rows, write_charts
from hybrid.studies.sweep import MANIFEST, model_data, system_from_data

EXACT = hybrid.SolverOptions(method=hybrid.Exact())
P_RANGE = (0.5, 1.5)

MODEL_TOML = """
[model]
name = "forced"
period = "2*pi/Omega"
initial_mode = "free"
[variables.x]
unit = "m"
[variables.v]
unit = "m/s"
[parameters.m]
[parameters.c]
[parameters.k]
[parameters.F]
[parameters.Omega]
domain = "positive"
[presets.standard]
m = 1.0
c = 0.1
k = 1.0
F = 1.0
Omega = 1.0
[equations]
x = "v"
v = "(F*sin(Omega*t) - c*v - k*x)/m"
[modes.free]
"""


def closed_form(p: dict, omega) -> np.ndarray:
    """Steady amplitude of the forced linear oscillator [m] at ``omega`` [rad/s]."""
    w = np.asarray(omega, dtype=float)
    return np.abs(p["F"] / (p["k"] - p["m"] * w**2 + 1j * p["c"] * w))


def with_acceleration(expr: str) -> hybrid.HybridSystem:
    """The forced oscillator with another expression of ``v'`` (a changed model)."""
    system, _, _, _ = forced_oscillator()
    return hybrid.HybridSystem(
        name=system.name,
        variables=system.variables,
        parameters=system.parameters,
        modes=[hybrid.Mode("free", derivatives={"x": "v", "v": expr})],
        transitions=[],
        period=system.period,
        initial_mode="free",
    )


@pytest.fixture(scope="module")
def oscillator():
    system, params, _, _ = forced_oscillator()
    return system, params


@pytest.fixture(scope="module")
def serial(oscillator, tmp_path_factory):
    """A 2 x 2 sweep over c and k run in this process (the reference of the executor tests)."""
    system, params = oscillator
    axes = [hybrid.linear_axis("c", 0.1, 0.2, 0.1), hybrid.log_axis("k", 0.8, 1.2, 2)]
    folder = tmp_path_factory.mktemp("serial")
    return axes, hybrid.sweep(system, params, axes, folder, p_range=P_RANGE, options=EXACT)


# ----------------------------------------------------------------------------------------------
def test_axes():
    assert hybrid.linear_axis("R", 0.3, 0.8, 0.05).values[-1] == 0.8
    assert len(hybrid.linear_axis("R", 0.3, 0.8, 0.05).values) == 11
    assert hybrid.linear_axis("R", 0.0, 1.0, 0.3).values == pytest.approx((0.0, 0.3, 0.6, 0.9), abs=1e-15)
    a = hybrid.log_axis("c3", 0.01, 10.0, 7)
    assert a.values[0] == 0.01
    assert a.values[-1] == 10.0
    assert np.allclose(np.diff(np.log(a.values)), math.log(1000.0) / 6, rtol=1e-12, atol=0)
    for args, match in [
        (("R", 1.0, 0.5, 0.1), "START <= STOP"),
        (("R", 0.0, 1.0, 0.0), "STEP must be > 0"),
        (("R", 0.0, math.inf, 0.1), "STOP must be a finite number"),
        (("R", 0.0, 1.0, 1e-9), "more than"),
    ]:
        with pytest.raises(ValueError, match=match):
            hybrid.linear_axis(*args)
    for args, match in [(("c", 0.0, 1.0, 5), "0 < START < STOP"), (("c", 0.1, 1.0, 1), "NUM must be")]:
        with pytest.raises(ValueError, match=match):
            hybrid.log_axis(*args)


def test_model_data_round_trip_and_hash():
    from hybrid import resolve_model

    for name in ("absorber", "isolator", "coulomb"):
        system = resolve_model(name)
        again = system_from_data(json.loads(json.dumps(model_data(system))))
        assert hybrid.model_hash(again) == hybrid.model_hash(system)
        assert model_data(again) == model_data(system)
    system, _, _, _ = forced_oscillator()
    assert hybrid.model_hash(with_acceleration("(F*sin(Omega*t) - c*v - k*x)/m + 0")) != hybrid.model_hash(
        system
    )


def test_points_against_closed_form(serial, oscillator):
    _, params = oscillator
    axes, res = serial
    assert res.complete
    assert sorted(res.computed) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert not res.reused
    for (i, j), r in res.points.items():
        p = {**params, "c": axes[0].values[i], "k": axes[1].values[j]}
        assert r["values"] == {"c": p["c"], "k": p["k"]}
        assert r["status"] == "bounded", r["message"]
        om, amp = np.asarray(r["curve"]["Omega"]), np.asarray(r["curve"]["amplitude"])
        assert om.min() == pytest.approx(P_RANGE[0], abs=1e-12)
        assert om.max() >= P_RANGE[1]  # the range covered
        assert np.allclose(amp, closed_form(p, om), rtol=1e-8, atol=0)
        assert r["peak"] == amp.max()
        assert r["peak_at"] == om[np.argmax(amp)]
        # the continuation resolves the resonance: its largest point is within 1e-3 of the true peak
        w_r = math.sqrt(p["k"] / p["m"] - p["c"] ** 2 / (2 * p["m"] ** 2))
        assert r["peak"] == pytest.approx(float(closed_form(p, w_r)), rel=1e-3)
        assert r["peak_stability"] == "stable"
    # the files hold the same results
    again = hybrid.load_sweep(res.folder)
    assert again.points == res.points


def test_unbounded_failed_and_time_limit_points_recorded(oscillator, tmp_path):
    system, params = oscillator
    # c = 0: undamped, the response grows without bound at Omega = sqrt(k/m) = 1
    res = hybrid.sweep(
        system,
        params,
        [hybrid.linear_axis("c", 0.0, 0.1, 0.1)],
        tmp_path / "a",
        p_range=P_RANGE,
        options=EXACT,
    )
    assert res.points[(0,)]["status"] == "unbounded"
    assert res.points[(1,)]["status"] == "bounded"
    assert res.points[(0,)]["reason"] == "unbounded"
    assert res.points[(1,)]["reason"] == ""
    assert any(lo < 1.0 < hi + 1e-6 for lo, hi in res.points[(0,)]["unbounded"])
    # m = 0: the equations divide by zero; the point is recorded with the exception, the next one runs
    res = hybrid.sweep(
        system,
        params,
        [hybrid.linear_axis("m", 0.0, 1.0, 1.0)],
        tmp_path / "b",
        p_range=P_RANGE,
        options=EXACT,
    )
    assert res.points[(0,)]["status"] == "failed"
    assert res.points[(0,)]["peak"] is None
    assert res.points[(0,)]["reason"] == "exception"
    assert "ZeroDivisionError" in res.points[(0,)]["message"]
    assert res.points[(1,)]["status"] == "bounded"
    res = hybrid.sweep(
        system,
        params,
        [hybrid.linear_axis("c", 0.1, 0.1, 0.1)],
        tmp_path / "c",
        p_range=P_RANGE,
        options=EXACT,
        point_time_limit=1e-6,
    )
    assert res.points[(0,)]["status"] == "time limit"
    assert res.points[(0,)]["reason"] == "time-limit"
    assert "time limit" in res.points[(0,)]["message"]


@pytest.mark.slow
def test_process_pool_equals_serial(serial, oscillator, tmp_path):
    system, params = oscillator
    axes, ref = serial
    with ProcessPoolExecutor(max_workers=2) as ex:
        res = hybrid.sweep(system, params, axes, tmp_path, p_range=P_RANGE, options=EXACT, executor=ex)
    assert res.complete
    assert not res.lost
    assert len({r["pid"] for r in res.points.values()} - {os.getpid()}) >= 1
    for k, r in ref.points.items():
        assert res.points[k]["curve"] == r["curve"]
        assert res.points[k]["peak"] == r["peak"]


@pytest.mark.slow
def test_dask_local_cluster_equals_serial(serial, oscillator, tmp_path):
    distributed = pytest.importorskip("distributed")  # the test extra installs it: CI runs this
    system, params = oscillator
    axes, ref = serial
    toml = tmp_path / "forced.toml"
    toml.write_text(MODEL_TOML)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        res = hybrid.sweep(
            system, params, axes, tmp_path / "lib", p_range=P_RANGE, options=EXACT, executor=client
        )
        # the CLI on the same cluster
        code = main(
            [
                "sweep",
                str(toml),
                "--param",
                "c",
                "0.1",
                "0.2",
                "0.1",
                "--param-log",
                "k",
                "0.8",
                "1.2",
                "2",
                "--omega-range",
                "0.5",
                "1.5",
                "--integrator",
                "exact",
                "--out",
                str(tmp_path / "cli"),
                "--scheduler",
                cluster.scheduler_address,
                "--no-progress",
            ]
        )
    assert code == 0
    cli = hybrid.load_sweep(tmp_path / "cli")
    for k, r in ref.points.items():
        assert res.points[k]["curve"] == r["curve"]
        assert res.points[k]["peak"] == r["peak"]
        assert cli.points[k]["curve"] == r["curve"]
    assert {r["pid"] for r in res.points.values()}.isdisjoint({os.getpid()})


def test_resume_refuses_a_changed_sweep(serial, oscillator, tmp_path):
    system, params = oscillator
    axes, ref = serial
    with pytest.raises(ValueError, match="already holds a sweep"):
        hybrid.sweep(system, params, axes, ref.folder, p_range=P_RANGE, options=EXACT)
    with pytest.raises(ValueError, match=r"`axes` differs"):
        finer = [axes[0], hybrid.log_axis("k", 0.8, 1.2, 3)]
        hybrid.sweep(system, params, finer, ref.folder, p_range=P_RANGE, options=EXACT, resume=True)
    with pytest.raises(ValueError, match=r"`params` differs"):
        hybrid.sweep(
            system, {**params, "F": 2.0}, axes, ref.folder, p_range=P_RANGE, options=EXACT, resume=True
        )
    changed = with_acceleration("(F*sin(Omega*t) - c*v - k*x)/m - 0.001*x")
    with pytest.raises(ValueError, match=r"`model_hash` differs.*model changed"):
        hybrid.sweep(changed, params, axes, ref.folder, p_range=P_RANGE, options=EXACT, resume=True)
    # resuming a finished sweep computes nothing
    res = hybrid.sweep(system, params, axes, ref.folder, p_range=P_RANGE, options=EXACT, resume=True)
    assert res.computed == []
    assert sorted(res.reused) == sorted(ref.points)
    assert res.points == ref.points


def children(pid: int) -> list[int]:
    """Child processes of ``pid`` (Linux /proc: the project runs on Linux, where the workers' death
    with their parent, PR_SET_PDEATHSIG, is what this test checks)."""
    out = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        out += [int(c) for c in (task / "children").read_text().split()]
    return out


def alive(pid: int) -> bool:
    """``pid`` exists and is not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


@pytest.mark.slow
def test_sigkill_then_resume_equals_uninterrupted_run(tmp_path):
    """Kill a running ``hybrid sweep`` with SIGKILL once a point is written; --resume finishes it."""
    toml = tmp_path / "forced.toml"
    toml.write_text(MODEL_TOML)
    out = tmp_path / "killed"
    args = [
        "sweep",
        str(toml),
        "--param",
        "c",
        "0.05",
        "0.5",
        "0.05",
        "--omega-range",
        "0.5",
        "1.5",
        "--integrator",
        "exact",
        "--out",
        str(out),
        "--workers",
        "1",
        "--no-progress",
    ]
    proc = subprocess.Popen(
        [sys.executable, "-c", "import sys; from hybrid.cli import main; sys.exit(main())", *args],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        t_end = time.monotonic() + 120
        while not list(out.glob("point-*.json")) and proc.poll() is None and time.monotonic() < t_end:
            time.sleep(0.005)
        workers = children(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        # its worker process dies with it (PR_SET_PDEATHSIG, hybrid.cli.sweep.die_with_parent)
        t_end = time.monotonic() + 30
        while any(alive(w) for w in workers) and time.monotonic() < t_end:
            time.sleep(0.01)
        assert workers
        assert not any(alive(w) for w in workers)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # its worker process too
        except ProcessLookupError:
            pass
        proc.wait()
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
    before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in out.glob("point-*.json")}
    assert 1 <= len(before) < 10  # killed with work left
    assert main([*args, "--resume"]) == 0
    after = hybrid.load_sweep(out)
    assert after.complete
    for name, stamp in before.items():  # finished points were not computed again
        p = out / name
        assert (p.stat().st_ino, p.stat().st_mtime_ns) == stamp
    # the same sweep uninterrupted (in this process, through the library)
    system = hybrid.load_system(toml)
    ref = hybrid.sweep(
        system,
        system.presets["standard"],
        after.axes,
        tmp_path / "ref",
        p_range=P_RANGE,
        options=hybrid.SolverOptions(method=hybrid.Exact()),
    )
    assert ref.manifest["model_hash"] == after.manifest["model_hash"]
    for k, r in ref.points.items():
        got = after.points[k]
        assert got["status"] == r["status"] == "bounded"
        np.testing.assert_allclose(got["curve"]["amplitude"], r["curve"]["amplitude"], rtol=1e-12, atol=0)
        np.testing.assert_allclose(got["curve"]["Omega"], r["curve"]["Omega"], rtol=1e-12, atol=0)


def test_charts(serial, oscillator, tmp_path):
    _, params = oscillator
    axes, res = serial
    files, lines = write_charts(res, tmp_path)
    names = {f.name for f in files}
    assert {"chart.csv", "chart.json", "chart_lines.png", "chart_plane.png"} <= names
    rows = chart_rows(res)
    assert len(rows) == 4

    # the optimum is the point whose closed-form peak over its continued frequencies is lowest
    def peak(r):
        p = {**params, "c": r["c"], "k": r["k"]}
        om = res.points[(axes[0].values.index(r["c"]), axes[1].values.index(r["k"]))]["curve"]["Omega"]
        return float(closed_form(p, om).max())

    best = min(rows, key=peak)
    assert [r["optimum"] for r in rows] == [int(r is best) for r in rows]
    assert best["c"] == 0.2  # more damping, a lower peak
    summary = json.loads((tmp_path / "chart.json").read_text())
    assert summary["optimum"]["values"] == {"c": best["c"], "k": best["k"]}
    assert any("lowest bounded peak" in line for line in lines)


def test_cli_bad_input_before_any_run(tmp_path, capsys):
    toml = tmp_path / "forced.toml"
    toml.write_text(MODEL_TOML)
    base = [
        "sweep",
        str(toml),
        "--omega-range",
        "0.5",
        "1.5",
        "--integrator",
        "exact",
        "--out",
        str(tmp_path / "o"),
    ]
    cases = [
        ([], "give at least one axis"),
        (["--param", "c", "1", "0", "0.1"], r"`--param c 1 0 0.1`: axis `c`: needs START <= STOP"),
        (["--param", "c", "0", "1", "x"], r"STEP 'x' is not a number"),
        (["--param-log", "c", "0", "1", "5"], r"a log axis needs 0 < START < STOP"),
        (["--param-log", "c", "0.1", "1", "2.5"], r"NUM '2.5' is not an integer"),
        (["--param", "zeta", "0", "1", "0.5"], r"no parameter `zeta`"),
        (["--param", "Omega", "0.5", "1", "0.5"], r"`Omega` is the forcing frequency .* cannot be an axis"),
        (["--param", "c", "0", "1", "0.5", "--param", "c", "0", "1", "0.5"], "appears on two axes"),
        (["--param", "c", "0", "1", "0.5", "--coordinate", "y"], "no variable or output `y`"),
    ]
    for extra, match in cases:
        assert main(base + extra) == 2
        err = capsys.readouterr().err
        assert "hybrid: error:" in err and __import__("re").search(match, err), (extra, err)
        assert not list((tmp_path / "o").glob("point-*"))
    (tmp_path / "o").mkdir(exist_ok=True)
    (tmp_path / "o" / MANIFEST).write_text("{}")
    assert main(base + ["--param", "c", "0.1", "0.1", "1"]) == 2
    assert "already holds a sweep: add --resume" in capsys.readouterr().err
    assert main(["chart", str(tmp_path)]) == 2
    assert "holds no sweep" in capsys.readouterr().err


def test_cli_records_a_failed_point_goes_on_and_exits_1(tmp_path, capsys):
    toml = tmp_path / "forced.toml"
    toml.write_text(MODEL_TOML)
    out = tmp_path / "o"
    args = ["sweep", str(toml), "--param", "m", "0", "1", "1", "--omega-range", "0.5", "1.5"]
    code = main([*args, "--integrator", "exact", "--out", str(out), "--workers", "1", "--no-progress"])
    captured = capsys.readouterr()
    assert code == 1
    assert "1 points failed or ran out of time" in captured.err
    assert "1 bounded" in captured.out
    assert "1 failed" in captured.out
    res = hybrid.load_sweep(out)
    assert res.points[(0,)]["status"] == "failed"
    assert res.points[(1,)]["status"] == "bounded"


def test_progress_bar_shows_done_failed_and_time_left():
    import io

    from hybrid.cli.sweep import _SweepBar

    bar = _SweepBar("sweep", True, 10)
    bar.bar.stream = io.StringIO()
    bar(0.2)  # two points found finished: the rate comes from the points computed now
    assert "2/10 done, 0 failed, time left: after the first point" in bar.bar.stream.getvalue()
    bar.t0 -= 60.0  # one point computed in 60 s: 7 left take 7 min
    bar.point((2,), {"status": "failed"})  # (on_point comes before progress)
    bar(0.3)
    assert "3/10 done, 1 failed, 7.0 min left" in bar.bar.stream.getvalue()
    bar.point((3,), {"status": "bounded"})
    bar(0.4)
    assert "4/10 done, 1 failed" in bar.bar.stream.getvalue()
    resumed = _SweepBar("sweep", True, 10, failed=2)  # two failed points found in the folder
    resumed.bar.stream = io.StringIO()
    resumed(0.5)
    assert "5/10 done, 2 failed" in resumed.bar.stream.getvalue()


@pytest.mark.slow
def test_chart_of_a_plane_with_unbounded_points(oscillator, tmp_path):
    system, params = oscillator
    axes = [hybrid.linear_axis("c", 0.0, 0.1, 0.1), hybrid.linear_axis("k", 0.8, 1.2, 0.4)]
    res = hybrid.sweep(system, params, axes, tmp_path / "s", p_range=P_RANGE, options=EXACT)
    files, lines = write_charts(res, tmp_path)
    summary = json.loads((tmp_path / "chart.json").read_text())
    # c = 0 is undamped: unbounded at its resonance sqrt(k/m), inside the range for both k
    assert sorted(v["k"] for v in summary["unbounded"]) == [0.8, 1.2]
    assert all(v["c"] == 0.0 for v in summary["unbounded"])
    assert summary["counts"]["unbounded"] == 2
    assert summary["counts"]["bounded"] == 2
    assert summary["optimum"]["values"]["c"] == 0.1
    assert "unbounded response at 2 points" in lines
    assert (tmp_path / "chart_plane.png").stat().st_size > 0


class _LosingExecutor:
    """Runs points in this process, but 'loses' the first (as a pool whose worker died would)."""

    def __init__(self):
        self.calls = 0

    def submit(self, fn, *args):
        from concurrent.futures import Future

        fut = Future()
        self.calls += 1
        if self.calls == 1:
            fut.set_exception(RuntimeError("worker process died"))
        else:
            fut.set_result(fn(*args))
        return fut


def test_points_lost_by_the_executor_have_no_file_and_are_computed_on_resume(oscillator, tmp_path):
    system, params = oscillator
    axes = [hybrid.linear_axis("c", 0.1, 0.2, 0.1)]
    kw = {"p_range": P_RANGE, "options": EXACT}
    res = hybrid.sweep(system, params, axes, tmp_path, executor=_LosingExecutor(), **kw)
    assert res.lost == [((0,), "RuntimeError: worker process died")]
    assert not res.complete
    assert not (tmp_path / "point-0000.json").exists()
    assert (tmp_path / "point-0001.json").exists()
    res = hybrid.sweep(system, params, axes, tmp_path, resume=True, **kw)
    assert res.computed == [(0,)]
    assert res.reused == [(1,)]
    assert res.complete


def test_point_files_without_a_manifest_are_refused(oscillator, tmp_path):
    system, params = oscillator
    (tmp_path / "point-0000.json").write_text("{}")
    with pytest.raises(ValueError, match="point files but no manifest.json"):
        hybrid.sweep(system, params, [hybrid.linear_axis("c", 0.1, 0.1, 1.0)], tmp_path, resume=True)
