"""Operations that never lose or mix results (issue 25): the adversarial catalogue re-run, measured.

Sections (``--only NAME`` runs one; all by default):

* ``concurrent``: two sweeps started at the same moment in one folder (the second with
  ``--set F=0.02``), ``--trials`` times (default 20): how many were accepted, and whether the folder
  ever mixes them (its manifest's F against the peak of every point file, each compared with the
  peaks of a reference sweep of each F computed first, to 1e-9 relative).
* ``signals``: ``hybrid frc``, ``hybrid reproduce --figure 7 --workers 2`` and ``hybrid sweep`` killed
  by SIGTERM, SIGKILL, SIGHUP and SIGINT once their workers run: the main process's exit code and
  time to end, and every process of the command's session 5 s after the signal (none should be left).
* ``fulldisk``: ``frc``, ``sweep`` and ``reproduce`` writing to a small tmpfs (root only) filled
  with a ballast file: the message; then the ballast removed and the command run again
  (``--resume`` for the sweep): the exit code and the files.
* ``catalogue``: each numbered case of the issue: exit code, the message (the first line of stderr
  saying ``hybrid:``, else the first line), wall time, peak memory of the main process (GNU
  ``time``), the files left in the output folder.

Prints Markdown tables (``--md FILE`` also writes them). Run from the repository with its
virtualenv active: ``python benchmarks/operations.py [--only catalogue] [--trials 20]``. Needs
Linux, GNU time, and root for the tmpfs cases (they are skipped otherwise, and said so). The load
of the machine is printed with each section.
"""

from __future__ import annotations

import argparse
import http.server
import json
import math
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HYBRID = [sys.executable, "-m", "hybrid.cli"]
ROWS: list[str] = []


def say(line: str = "") -> None:
    print(line, flush=True)
    ROWS.append(line)


def load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def run(args, cwd: Path, timeout: float = 900, stdin=None, stdout=None, shell: str | None = None, out=None):
    """Run ``hybrid ARGS`` (or a shell line) under GNU time: exit code, message, wall, peak MB, files."""
    tfile = cwd / ".time"
    cmd = ["/usr/bin/time", "-f", "%e %M", "-o", str(tfile)]
    cmd += ["bash", "-c", shell] if shell is not None else [*HYBRID, *args]
    t0 = time.perf_counter()
    try:
        p = subprocess.run(
            cmd,
            cwd=cwd,
            timeout=timeout,
            stdin=stdin,
            stdout=stdout or subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        code, err, sout = p.returncode, p.stderr, p.stdout or ""
    except subprocess.TimeoutExpired as exc:
        code, err, sout = (
            "timeout",
            (exc.stderr or b"").decode() if isinstance(exc.stderr, bytes) else exc.stderr or "",
            "",
        )
    wall = time.perf_counter() - t0
    peak = math.nan
    try:
        for line in tfile.read_text().splitlines():
            parts = line.split()
            if len(parts) == 2 and parts[1].isdigit():
                peak = int(parts[1]) / 1024
    except OSError:
        pass
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("Command exited")]
    verdict = [ln for ln in lines if ln.startswith("hybrid:")]
    msg = verdict[0] if verdict else lines[0] if lines else (sout.splitlines() or [""])[0]
    if "Traceback" in err:
        msg = "TRACEBACK: " + (lines[-1] if lines else "")
    files = ""
    if out is not None:
        o = cwd / out
        files = _listing(o)
    return code, msg, wall, peak, files


def _listing(o: Path) -> str:
    """The names in folder ``o``, its point files counted rather than listed."""
    if not o.is_dir():
        return "(no folder)"
    names = sorted(p.name for p in o.iterdir())
    points = [n for n in names if n.startswith("point-") and n.endswith(".json")]
    rest = [n for n in names if n not in points]
    return " ".join(rest + ([f"+ {len(points)} point files"] if points else []))


def cut(text: str, n: int = 170) -> str:
    text = text.replace("|", "/")
    return text if len(text) <= n else text[: n - 3] + "..."


def load1() -> str:
    """The 1-minute load average now (the machine is shared: every timing is given with it)."""
    return f"{os.getloadavg()[0]:.2f}"


def table_row(case: str, res) -> None:
    code, msg, wall, peak, files = res
    say(f"| {case} | {code} | {cut(msg)} | {wall:.1f} | {peak:.0f} | {load1()} | {cut(files, 90) or '-'} |")


def header(title: str) -> None:
    say()
    say(f"### {title} ({load()})")
    say()
    say("| case | exit | message | wall [s] | peak [MB] | load (1 min) | files left |")
    say("|---|---|---|---|---|---|---|")


# ----------------------------------------------------------------------------------------------
def concurrent(trials: int) -> None:
    base = ["sweep", "absorber", "--param", "R", "0.3", "0.4", "0.1", "--integrator", "exact"]
    base += ["--omega-range", "0.85", "0.86", "--workers", "1", "--no-progress"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ref = {}
        for f in ("0.01", "0.02"):
            subprocess.run(
                [*HYBRID, *base, "--set", f"F={f}", "--out", str(tmp / f"ref{f}")],
                check=True,
                capture_output=True,
            )
            ref[float(f)] = {
                p.name: json.loads(p.read_text())["peak"]
                for p in sorted((tmp / f"ref{f}").glob("point-*.json"))
            }
        say()
        say(f"### Two concurrent sweeps in one folder, {trials} trials ({load()})")
        say()
        say(
            f"reference peaks: F = 0.01: {sorted(ref[0.01].values())}; F = 0.02: {sorted(ref[0.02].values())}"
        )
        say()
        both = mixed = 0
        outcomes = []
        for k in range(trials):
            out = tmp / f"s{k}"
            cmds = [
                [*HYBRID, *base, "--out", str(out)],
                [*HYBRID, *base, "--set", "F=0.02", "--out", str(out)],
            ]
            procs = [
                subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for c in cmds
            ]
            res = [(p.wait(), p.stderr.read()) for p in procs]
            accepted = [c for c, _ in res if c != 2]
            both += len(accepted) == 2
            m = json.loads((out / "manifest.json").read_text())
            f = m["params"]["F"]
            points = {p.name: json.loads(p.read_text())["peak"] for p in sorted(out.glob("point-*.json"))}
            ok = set(points) == set(ref[f]) and all(
                math.isclose(points[n], ref[f][n], rel_tol=1e-9) for n in points
            )
            mixed += not ok
            refused = [e.strip().splitlines()[-1] for c, e in res if c == 2]
            outcomes.append((tuple(c for c, _ in res), f, ok, refused[0] if refused else ""))
        say(
            "| trial | exit codes (F=0.01, F=0.02) | manifest F | points match that F | the refused run's message |"
        )
        say("|---|---|---|---|---|")
        for k, (codes, f, ok, msg) in enumerate(outcomes):
            say(f"| {k + 1} | {codes} | {f} | {ok} | {cut(msg, 150)} |")
        say()
        say(f"**both accepted in {both} of {trials} trials; mixed folder in {mixed} of {trials}**")


# ----------------------------------------------------------------------------------------------
def _session(sid: int) -> list[tuple]:
    found = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            st = Path(f"/proc/{d}/stat").read_text()
            fields = st[st.rindex(")") + 2 :].split()
            if int(fields[3]) == sid and fields[0] != "Z":
                cmd = Path(f"/proc/{d}/cmdline").read_text().replace("\0", " ").strip()
                found.append((int(d), int(fields[1]), cmd[:50]))
        except (OSError, ValueError):
            continue
    return found


def _naming(text: str) -> list[tuple]:
    """Every live process whose command line contains ``text`` (a forked worker keeps its parent's)."""
    found = []
    for d in os.listdir("/proc"):
        if not d.isdigit() or int(d) == os.getpid():
            continue
        try:
            cmd = Path(f"/proc/{d}/cmdline").read_text().replace("\0", " ").strip()
            st = Path(f"/proc/{d}/stat").read_text()
            fields = st[st.rindex(")") + 2 :].split()
            if text in cmd and fields[0] != "Z":
                found.append((int(d), int(fields[1]), cmd[:50]))
        except (OSError, ValueError):
            continue
    return found


def kill_case(args: list[str], sig: int, cwd: Path, procs: int = 3) -> tuple:
    p = subprocess.Popen(
        [*HYBRID, *args],
        cwd=cwd,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    t0 = time.time()
    while time.time() - t0 < 60 and len(_session(p.pid)) < procs and p.poll() is None:
        time.sleep(0.05)
    time.sleep(1.0)
    before = _session(p.pid)
    t1 = time.time()
    os.kill(p.pid, sig)
    try:
        _, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        err = "(still running 60 s after the signal)"
    ended = time.time() - t1
    time.sleep(max(0.0, 5.0 - (time.time() - t1)))
    after = sorted(set(_session(p.pid)) | set(_naming(str(cwd))))  # (a worker that left the session too)
    last = [ln for ln in err.splitlines() if ln.startswith("hybrid:")]
    return len(before), p.returncode, ended, after, last[-1] if last else ""


def signals() -> None:
    say()
    say(f"### Signals to the multi-process commands ({load()})")
    say()
    say(
        "| command | signal | processes before | exit code | main ended after [s] | load (1 min) | processes of its session 5 s after the signal | last line |"
    )
    say("|---|---|---|---|---|---|---|---|")
    commands = {
        "frc absorber": ["frc", "absorber", "--no-progress"],
        "reproduce --figure 7 --workers 2": ["reproduce", "--figure", "7", "--workers", "2", "--no-progress"],
        "sweep absorber (6 points, 2 workers)": [
            "sweep",
            "absorber",
            "--param",
            "R",
            "0.3",
            "0.8",
            "0.1",
            "--integrator",
            "exact",
            "--omega-range",
            "0.8",
            "1.2",
            "--workers",
            "2",
            "--no-progress",
        ],
    }
    for name, args in commands.items():
        for sig in (signal.SIGTERM, signal.SIGKILL, signal.SIGHUP, signal.SIGINT):
            with tempfile.TemporaryDirectory() as tmp:
                n, code, ended, after, last = kill_case(
                    [*args, "--out", str(Path(tmp) / "o")], sig, Path(tmp)
                )
            say(
                f"| {name} | {sig.name} | {n} | {code} | {ended:.1f} | {load1()} | {after or 'none'} | {cut(last, 120)} |"
            )
    # SIGINT to a sweep's main process alone, a larger grid: how soon it ends, what it keeps
    with tempfile.TemporaryDirectory() as tmp:
        args = [
            "sweep",
            "absorber",
            "--param",
            "R",
            "0.3",
            "0.8",
            "0.02",
            "--integrator",
            "exact",
            "--workers",
            "2",
            "--no-progress",
            "--out",
            str(Path(tmp) / "o"),
        ]
        p = subprocess.Popen(
            [*HYBRID, *args],
            cwd=tmp,
            start_new_session=True,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        while not list((Path(tmp) / "o").glob("point-*.json")) and p.poll() is None:
            time.sleep(0.05)
        t1 = time.time()
        os.kill(p.pid, signal.SIGINT)
        p.communicate(timeout=120)
        ended = time.time() - t1
        time.sleep(max(0.0, 5.0 - ended))
        kept = len(list((Path(tmp) / "o").glob("point-*.json")))
        say()
        say(
            f"SIGINT to the main process of a 26-point sweep after its first point: it ended {ended:.1f} s later "
            f"(exit {p.returncode}), {kept} point files kept, processes left: {_session(p.pid) or 'none'}"
        )


# ----------------------------------------------------------------------------------------------
def _mount(path: Path, size: str, inodes: int | None = None) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    opts = f"size={size}" + (f",nr_inodes={inodes}" if inodes else "")
    return (
        subprocess.run(
            ["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(path)], capture_output=True
        ).returncode
        == 0
    )


def _umount(path: Path) -> None:
    subprocess.run(["umount", str(path)], capture_output=True)


def fulldisk() -> None:
    header("A full disk during frc, sweep and reproduce: the message, then a rerun after space is freed")
    if os.geteuid() != 0:
        say(
            "| (not root: no tmpfs; see tests/test_operations.py for the faults injected at the write) | | | | | |"
        )
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        fs = tmp / "fs"
        cases = [
            (
                "frc absorber --integrator exact",
                ["frc", "absorber", "--integrator", "exact", "--no-progress"],
                300,
                None,
            ),
            (
                "sweep absorber, 26 points",
                [
                    "sweep",
                    "absorber",
                    "--param",
                    "R",
                    "0.3",
                    "0.8",
                    "0.02",
                    "--integrator",
                    "exact",
                    "--omega-range",
                    "0.8",
                    "1.2",
                    "--workers",
                    "2",
                    "--no-progress",
                ],
                80,  # (more than the 64 KiB checked up front; fills after about 17 point files)
                ["--resume"],
            ),
            ("reproduce --figure 5", ["reproduce", "--figure", "5", "--no-progress"], 68, None),
        ]
        for name, args, free_kb, again in cases:
            if not _mount(fs, "4m"):
                say(f"| {name} | (mount failed) | | | | |")
                continue
            try:
                ballast = fs / "ballast"
                size = shutil.disk_usage(fs).free - free_kb * 1024
                with open(ballast, "wb") as fh:
                    fh.write(b"\0" * size)
                table_row(
                    f"{name}, {free_kb} KB free", run([*args, "--out", str(fs / "o")], tmp, out=fs / "o")
                )
                ballast.unlink()
                table_row(
                    f"{name} again after freeing space" + (f" ({' '.join(again)})" if again else ""),
                    run([*args, "--out", str(fs / "o"), *(again or [])], tmp, out=fs / "o"),
                )
            finally:
                _umount(fs)


# ----------------------------------------------------------------------------------------------
class _Silent(threading.Thread):
    """A TCP listener that accepts and never answers (or announces an absurd frame length)."""

    def __init__(self, absurd: bool = False):
        super().__init__(daemon=True)
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.port = self.sock.getsockname()[1]
        self.absurd = absurd
        self.conns = []

    def run(self):
        while True:
            c, _ = self.sock.accept()
            self.conns.append(c)
            if self.absurd:
                c.sendall(struct.pack("Q", 2**62) + b"\0" * 64)


def catalogue(scheduler: str | None) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="hybrid-ops-"))
    try:
        _catalogue(tmp, scheduler)
    finally:
        for m in ("fs", "ro", "ino"):
            _umount(tmp / m)
        shutil.rmtree(tmp, ignore_errors=True)


def _catalogue(tmp: Path, scheduler: str | None) -> None:
    sweep_ab = [
        "sweep",
        "absorber",
        "--param",
        "R",
        "0.3",
        "0.4",
        "0.1",
        "--integrator",
        "exact",
        "--omega-range",
        "0.85",
        "0.86",
        "--no-progress",
    ]
    header("2. Sweeps of sign() models")
    table_row(
        "sweep coulomb_sign --param R 0.05 0.1 0.05 --omega-range 0.5 0.7",
        run(
            [
                "sweep",
                "coulomb_sign",
                "--param",
                "R",
                "0.05",
                "0.1",
                "0.05",
                "--omega-range",
                "0.5",
                "0.7",
                "--no-progress",
                "--out",
                "cs",
            ],
            tmp,
            out="cs",
        ),
    )
    table_row(
        "hybrid.model_hash(coulomb_sign), belt_sign",
        run(
            [],
            tmp,
            shell=f"{sys.executable} -c \"import hybrid; print(hybrid.model_hash(hybrid.resolve_model('coulomb_sign'))[:16], hybrid.model_hash(hybrid.resolve_model('belt_sign'))[:16])\"",
        ),
    )

    header("4. Schedulers and budgets of sweep and reproduce")
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    silent, absurd = _Silent(), _Silent(absurd=True)
    silent.start()
    absurd.start()
    for name, addr in (
        ("--scheduler at python -m http.server", f"tcp://127.0.0.1:{httpd.server_address[1]}"),
        ("--scheduler at a silent listener", f"tcp://127.0.0.1:{silent.port}"),
        ("--scheduler announcing an absurd frame length", f"tcp://127.0.0.1:{absurd.port}"),
        ("--scheduler ws:// at http.server", f"ws://127.0.0.1:{httpd.server_address[1]}"),
    ):
        table_row(name, run([*sweep_ab, "--scheduler", addr, "--out", "d"], tmp, out="d"))
    if scheduler:
        table_row(
            "--scheduler without workers (--worker-wait 10)",
            run([*sweep_ab, "--scheduler", scheduler, "--worker-wait", "10", "--out", "dw"], tmp, out="dw"),
        )
    else:
        say(
            "| --scheduler without workers | (give --scheduler ADDRESS of a scheduler without workers) | | | | |"
        )
    table_row(
        "sweep absorber 11 points --max-time 8",
        run(
            [
                "sweep",
                "absorber",
                "--param",
                "R",
                "0.3",
                "0.8",
                "0.05",
                "--integrator",
                "exact",
                "--omega-range",
                "0.8",
                "1.2",
                "--no-progress",
                "--max-time",
                "8",
                "--out",
                "mt",
            ],
            tmp,
            out="mt",
        ),
    )
    table_row(
        "  then --resume",
        run(
            [
                "sweep",
                "absorber",
                "--param",
                "R",
                "0.3",
                "0.8",
                "0.05",
                "--integrator",
                "exact",
                "--omega-range",
                "0.8",
                "1.2",
                "--no-progress",
                "--resume",
                "--out",
                "mt",
            ],
            tmp,
            out="mt",
        ),
    )
    table_row(
        "reproduce --figure 7 --max-time 5",
        run(["reproduce", "--figure", "7", "--no-progress", "--max-time", "5", "--out", "rm"], tmp, out="rm"),
    )

    header("5. Full disks and unwritable places")
    if os.geteuid() == 0 and _mount(tmp / "fs", "256k"):
        fs = tmp / "fs"
        with open(fs / "ballast", "wb") as fh:
            fh.write(b"\0" * (shutil.disk_usage(fs).free - 100 * 1024))
        for name, args in (
            ("simulate absorber", ["simulate", "absorber", "--periods", "400"]),
            ("orbit absorber", ["orbit", "absorber"]),
            ("frc absorber (CSV and PNG)", ["frc", "absorber", "--integrator", "exact", "--no-progress"]),
            (
                "cont belt_stribeck",
                ["cont", "belt_stribeck", "--param", "v_b", "--range", "0.05", "2.5", "--max-time", "30"],
            ),
            (
                "sweep absorber",
                [
                    "sweep",
                    "absorber",
                    "--param",
                    "R",
                    "0.3",
                    "0.8",
                    "0.05",
                    "--integrator",
                    "exact",
                    "--omega-range",
                    "0.8",
                    "1.2",
                    "--no-progress",
                ],
            ),
            ("reproduce --figure 5", ["reproduce", "--figure", "5", "--no-progress"]),
        ):
            shutil.rmtree(fs / "o", ignore_errors=True)
            table_row(f"{name}, 100 KB free", run([*args, "--out", str(fs / "o")], tmp, out=fs / "o"))
        shutil.rmtree(fs / "o", ignore_errors=True)
        net = Path(__file__).resolve().parents[1] / "models" / "absorber_network.toml"
        if net.exists():
            with open(fs / "ballast2", "wb") as fh:
                try:
                    fh.write(b"\0" * shutil.disk_usage(fs).free)
                except OSError:
                    pass
            table_row(
                "show NETWORK --out PNG on a full disk",
                run(["show", str(net), "--out", str(fs / "n.png")], tmp),
            )
        _umount(fs)
        if _mount(tmp / "ino", "4m", inodes=6):
            table_row(
                "sweep on a file system out of inodes",
                run([*sweep_ab, "--out", str(tmp / "ino" / "o")], tmp, out=tmp / "ino" / "o"),
            )
            _umount(tmp / "ino")
        if _mount(tmp / "ro", "1m"):
            subprocess.run([*HYBRID, *sweep_ab, "--out", str(tmp / "ro" / "sw")], capture_output=True)
            subprocess.run(["mount", "-o", "remount,ro", str(tmp / "ro")], capture_output=True)
            table_row(
                "chart of a sweep on a read-only file system", run(["chart", str(tmp / "ro" / "sw")], tmp)
            )
            table_row(
                "simulate --out on a read-only file system",
                run(["simulate", "absorber", "--periods", "1", "--out", str(tmp / "ro" / "x")], tmp),
            )
            table_row(
                "reproduce --report on a read-only file system",
                run(["reproduce", "--figure", "5", "--out", "rr", "--report", str(tmp / "ro" / "r.md")], tmp),
            )
            _umount(tmp / "ro")
    else:
        say("| (not root: no tmpfs) | | | | | |")
    table_row(
        "simulate --out with a 300-character name",
        run(["simulate", "absorber", "--periods", "1", "--out", "x" * 300], tmp),
    )
    (tmp / "sj").mkdir()
    (tmp / "sj" / "summary.json").mkdir()
    table_row(
        "simulate with summary.json a folder",
        run(["simulate", "absorber", "--periods", "1", "--out", "sj"], tmp, out="sj"),
    )
    table_row("hybrid models / head -1", run([], tmp, shell=f"{' '.join(HYBRID)} models | head -1"))
    table_row("hybrid models > /dev/full", run([], tmp, shell=f"{' '.join(HYBRID)} models > /dev/full"))
    table_row("hybrid models >&- (stdout closed)", run([], tmp, shell=f"{' '.join(HYBRID)} models >&-"))
    table_row(
        "simulate 2>&- (stderr closed)",
        run(
            [],
            tmp,
            shell=f"{' '.join(HYBRID)} simulate absorber --periods 1 --out sc 2>&-; echo exit $?",
            out="sc",
        ),
    )
    table_row(
        "reproduce --report /nonexistent/dir/r.md",
        run(["reproduce", "--figure", "5", "--out", "rn", "--report", "/nonexistent/dir/r.md"], tmp),
    )

    header("6. Budgets and interrupts")
    table_row(
        "cont belt_stribeck --max-time 2",
        run(
            [
                "cont",
                "belt_stribeck",
                "--param",
                "v_b",
                "--range",
                "0.05",
                "2.5",
                "--max-time",
                "2",
                "--out",
                "c1",
            ],
            tmp,
            out="c1",
        ),
    )
    table_row(
        "cont belt_stribeck --max-steps 100",
        run(
            [
                "cont",
                "belt_stribeck",
                "--param",
                "v_b",
                "--range",
                "0.05",
                "2.5",
                "--max-steps",
                "100",
                "--out",
                "c2",
            ],
            tmp,
            out="c2",
        ),
    )
    table_row(
        "cont belt_damper --max-time 1",
        run(
            [
                "cont",
                "belt_damper",
                "--param",
                "v_b",
                "--range",
                "0.05",
                "2.5",
                "--max-time",
                "1",
                "--out",
                "c3",
            ],
            tmp,
            out="c3",
        ),
    )
    for name, args, after in (
        (
            "Ctrl-C in cont belt_damper",
            ["cont", "belt_damper", "--param", "v_b", "--range", "0.05", "2.5", "--out", "i1"],
            4.0,
        ),
        ("Ctrl-C in simulate belt --t-end 1e5", ["simulate", "belt", "--t-end", "1e5", "--out", "i2"], 4.0),
        ("Ctrl-C in orbit absorber", ["orbit", "absorber", "--out", "i3"], 1.5),
        (
            "Ctrl-C in reproduce --figure 7",
            ["reproduce", "--figure", "7", "--no-progress", "--out", "i4"],
            6.0,
        ),
    ):
        table_row(name + f" after {after:g} s", _interrupt(args, tmp, after, args[-1]))

    header("7. Edited or corrupted sweep files (chart, then --resume)")
    good = tmp / "good"
    subprocess.run([*HYBRID, *sweep_ab, "--out", str(good)], capture_output=True)
    manifest = json.loads((good / "manifest.json").read_text())
    edits = {
        "manifest []": ("manifest.json", []),
        "manifest null": ("manifest.json", None),
        "manifest a string": ("manifest.json", "x"),
        "manifest without axes": ("manifest.json", {k: v for k, v in manifest.items() if k != "axes"}),
        "manifest without options": ("manifest.json", {k: v for k, v in manifest.items() if k != "options"}),
        "manifest, an axis without name": (
            "manifest.json",
            {**manifest, "axes": [{k: v for k, v in manifest["axes"][0].items() if k != "name"}]},
        ),
        "manifest 100,000 x 100,000 values": (
            "manifest.json",
            {
                **manifest,
                "axes": [
                    {**manifest["axes"][0], "name": "R", "values": [0.3 + i * 1e-6 for i in range(100_000)]},
                    {**manifest["axes"][0], "name": "c3", "values": [1 + i * 1e-6 for i in range(100_000)]},
                ],
            },
        ),
        "point file []": ("point-0000.json", []),
        "point file null": ("point-0000.json", None),
        "point file without status": ("point-0000.json", "drop:status"),
        "point file without values": ("point-0000.json", "drop:values"),
        "point file a folder": ("point-0000.json", "dir"),
        "point file with a NaN peak": ("point-0000.json", "nan"),
    }
    for name, (fname, content) in edits.items():
        d = tmp / "edit"
        shutil.rmtree(d, ignore_errors=True)
        shutil.copytree(good, d)
        target = d / fname
        if content == "dir":
            target.unlink()
            target.mkdir()
        elif isinstance(content, str) and content.startswith("drop:"):
            r = json.loads(target.read_text())
            r.pop(content[5:])
            target.write_text(json.dumps(r))
        elif content == "nan":
            target.write_text(target.read_text().replace('"peak": ', '"peak": NaN, "_": ', 1))
        else:
            target.write_text(json.dumps(content))
        table_row(f"chart: {name}", run(["chart", str(d)], tmp))
        table_row(f"--resume: {name}", run([*sweep_ab, "--resume", "--out", str(d)], tmp))

    header("8. Pre-planted entries")
    outside = tmp / "outside.txt"
    outside.write_text("precious\n")
    (tmp / "pl").mkdir()
    (tmp / "pl" / "events.csv").symlink_to(outside)
    table_row(
        "events.csv a symlink to a file outside",
        run(["simulate", "absorber", "--periods", "1", "--out", "pl"], tmp, out="pl"),
    )
    say(f"| (the outside file afterwards) | | {outside.read_text().strip()!r} | | | |")
    (tmp / "ff").mkdir()
    os.mkfifo(tmp / "ff" / "summary.json")
    table_row(
        "summary.json a FIFO",
        run(["simulate", "absorber", "--periods", "1", "--out", "ff"], tmp, out="ff", timeout=60),
    )

    header("9. Memory and workers")
    table_row(
        "simulate belt --t-end 250000 --no-plot --max-time 60",
        run(
            ["simulate", "belt", "--t-end", "250000", "--no-plot", "--max-time", "60", "--out", "m1"],
            tmp,
            out="m1",
        ),
    )
    table_row(
        "simulate belt --t-end 1e5 (figure) --max-time 20",
        run(["simulate", "belt", "--t-end", "1e5", "--max-time", "20", "--out", "m2"], tmp, out="m2"),
    )
    table_row(
        "sweep 2 points --workers 300", _count_procs([*sweep_ab, "--workers", "300", "--out", "w1"], tmp)
    )
    table_row(
        "reproduce --figure 5 --workers 200",
        _count_procs(["reproduce", "--figure", "5", "--workers", "200", "--out", "w2"], tmp),
    )

    header("10. Smaller items")
    (tmp / "absorber").write_text("[model]\nformat = 'network'\nname = 'other'\n")
    table_row("show absorber with a file `absorber` here", run(["show", "absorber"], tmp))
    table_row(
        "simulate absorber with a file `absorber` here",
        run(["simulate", "absorber", "--periods", "1", "--no-plot", "--out", "ab"], tmp),
    )
    table_row(
        "sweep --coordinate W (a quadrature)",
        run([*sweep_ab, "--coordinate", "W", "--out", "q"], tmp, out="q"),
    )
    table_row(
        "sweep --param Omega",
        run(["sweep", "absorber", "--param", "Omega", "0.85", "0.86", "0.01", "--out", "om"], tmp, out="om"),
    )
    table_row(
        "sweep isolator --point-time-limit 30 (ida, 1 point)",
        run(
            [
                "sweep",
                "isolator",
                "--param",
                "R",
                "1.0",
                "1.0",
                "0.1",
                "--point-time-limit",
                "30",
                "--no-progress",
                "--out",
                "ptl",
            ],
            tmp,
            out="ptl",
        ),
    )
    pts = sorted((tmp / "ptl").glob("point-*.json"))
    if pts:
        r = json.loads(pts[0].read_text())
        say(
            f"| (its point) | | {r['status']}, {r['seconds']:.2f} s: {cut(r.get('message', ''), 120)} | | | |"
        )
    py = (
        "import hybrid, tempfile, pathlib\n"
        "s = hybrid.resolve_model('absorber'); p = s.presets['standard']; a = [hybrid.linear_axis('R', 0.3, 0.4, 0.1)]\n"
        "f = pathlib.Path(tempfile.mkdtemp()) / 'file'; f.write_text('x')\n"
        "for kw in (dict(executor=object()), dict(point_time_limit=True)):\n"
        "    try: hybrid.sweep(s, p, a, tempfile.mkdtemp(), p_range=(0.85, 0.86), **kw)\n"
        "    except Exception as e: print(type(e).__name__ + ': ' + str(e)[:110])\n"
        "try: hybrid.sweep(s, p, a, f, p_range=(0.85, 0.86))\n"
        "except Exception as e: print(type(e).__name__ + ': ' + str(e)[:110])\n"
    )
    code, out, *_ = _py(py, tmp)
    for line in out.splitlines():
        say(f"| library: {cut(line.split(':')[0], 40)} | - | {cut(line)} | | | |")
    table_row(
        "sweep --param R 0.1 0.2 1e-300",
        run(["sweep", "absorber", "--param", "R", "0.1", "0.2", "1e-300", "--out", "tiny"], tmp),
    )


def _py(code: str, cwd: Path):
    p = subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def _interrupt(args, cwd: Path, after: float, out: str):
    tfile = cwd / ".time"
    p = subprocess.Popen(
        ["/usr/bin/time", "-f", "%e %M", "-o", str(tfile), *HYBRID, *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    time.sleep(after)
    t0 = time.perf_counter()
    for pid in _session(p.pid):
        if "hybrid.cli" in pid[2] and pid[1] == p.pid:
            os.kill(pid[0], signal.SIGINT)
    _, err = p.communicate(timeout=120)
    wall = time.perf_counter() - t0
    lines = [ln for ln in err.splitlines() if ln.startswith("hybrid:")]
    msg = ("TRACEBACK: " if "Traceback" in err else "") + (lines[-1] if lines else "")
    peak = math.nan
    try:
        peak = int(tfile.read_text().split()[-1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    o = cwd / out
    files = " ".join(sorted(x.name for x in o.iterdir())) if o.is_dir() else "(no folder)"
    return p.returncode, msg + f" (ended {wall:.1f} s after SIGINT)", after + wall, peak, files


def _count_procs(args, cwd: Path):
    p = subprocess.Popen(
        [*HYBRID, *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    most = 0
    t0 = time.perf_counter()
    while p.poll() is None:
        most = max(most, len(_session(p.pid)))
        time.sleep(0.05)
    err = p.stderr.read()
    note = [ln for ln in err.splitlines() if ln.startswith("note:")]
    return (
        p.returncode,
        (note[0] if note else "") + f"; most processes at once: {most}",
        time.perf_counter() - t0,
        math.nan,
        "",
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=("concurrent", "signals", "fulldisk", "catalogue"), action="append")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--scheduler", default=None, help="address of a Dask scheduler without workers")
    ap.add_argument("--md", default=None, help="also write the tables to this Markdown file")
    a = ap.parse_args()
    only = a.only or ["concurrent", "signals", "fulldisk", "catalogue"]
    say(f"`python benchmarks/operations.py` on {os.cpu_count()} CPUs, {load()}")
    if "concurrent" in only:
        concurrent(a.trials)
    if "signals" in only:
        signals()
    if "fulldisk" in only:
        fulldisk()
    if "catalogue" in only:
        catalogue(a.scheduler)
    if a.md:
        Path(a.md).write_text("\n".join(ROWS) + "\n")


if __name__ == "__main__":
    main()
