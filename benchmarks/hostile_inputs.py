"""Hostile and careless input, re-run as a user would (issue 13): exit code, first line, time, memory.

Each case is one ``hybrid`` command (or one library call through ``python -c``) run in a fresh
process under ``/usr/bin/time``, with its own scratch folder as the working directory; the table
gives the exit code, the first line of stderr (or stdout), the wall time and the peak resident
memory. Files a case must not write are checked afterwards.

Run: ``python benchmarks/hostile_inputs.py [--only SUBSTRING] [--timeout SECONDS]`` (a few minutes;
prints a Markdown table). A case still running at the timeout is killed and reported as such.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COULOMB = (ROOT / "models" / "coulomb.toml").read_text()


def _coulomb(**replace: str) -> str:
    text = COULOMB
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def _definitions(extra: str) -> str:
    return _coulomb(**{"[definitions]\n": "[definitions]\n" + extra})


SQUARES = "".join(f'a{k} = "{"x" if k == 0 else f"a{k - 1}*a{k - 1}"}"\n' for k in range(21))
UNUSED = "".join(f'd{k} = "x*{k} + v"\n' for k in range(300_000))
PY = sys.executable


def _lib(code: str) -> str:
    """A library call as a script: a raised exception is printed as its type and message (exit code 2)."""
    body = "\n".join("    " + line for line in code.splitlines())
    return (
        "import sys, hybrid_models, hybrid\ntry:\n" + body + "\nexcept Exception as exc:\n"
        "    print(f'{type(exc).__name__}: {exc}', file=sys.stderr)\n    sys.exit(2)"
    )


#: (label, files to write {name: text or bytes or None for a 2 GB sparse file}, argv, paths that must not exist)
CASES: list[tuple[str, dict, list[str], list[str]]] = [
    ("model name ../../../../elsewhere/escaped", {"m.toml": _coulomb(**{'name = "coulomb"': 'name = "../../../../elsewhere/escaped"'})}, ["hybrid", "simulate", "m.toml", "--t-end", "1"], ["../../../../elsewhere"]),
    ("model name absolute path", {"m.toml": _coulomb(**{'name = "coulomb"': 'name = "/tmp/hybrid-escaped"'})}, ["hybrid", "simulate", "m.toml", "--t-end", "1"], ["/tmp/hybrid-escaped"]),
    ("20 levels of a_k = a_{k-1}*a_{k-1}", {"m.toml": _definitions(SQUARES).replace('outputs = ["H"', 'outputs = ["a20", "H"')}, ["hybrid", "simulate", "m.toml", "--periods", "1", "--no-plot"], []),
    ("300 000 unused definitions (file size)", {"m.toml": _definitions(UNUSED)}, ["hybrid", "simulate", "m.toml", "--periods", "1"], []),
    ("2 GB sparse file", {"m.toml": None}, ["hybrid", "simulate", "m.toml"], []),
    ("sum of 3000 terms", {"m.toml": _coulomb(**{'v = "(force - k*x + friction)/m"': 'v = "' + "+".join(["x"] * 3000) + '"'})}, ["hybrid", "simulate", "m.toml"], []),
    ("3000 unary minuses", {"m.toml": _coulomb(**{'v = "(force - k*x + friction)/m"': 'v = "' + "-" * 3000 + 'x"'})}, ["hybrid", "simulate", "m.toml"], []),
    ("401-digit integer literal", {"m.toml": _coulomb(**{'v = "(force - k*x + friction)/m"': 'v = "' + "1" * 401 + '"'})}, ["hybrid", "simulate", "m.toml"], []),
    ("output 1/x", {"m.toml": _definitions('q = "1/x"\n').replace('outputs = ["H"', 'outputs = ["q", "H"')}, ["hybrid", "simulate", "m.toml", "--periods", "1", "--no-plot"], []),
    ("output log(x)", {"m.toml": _definitions('q = "log(x)"\n').replace('outputs = ["H"', 'outputs = ["q", "H"')}, ["hybrid", "simulate", "m.toml", "--periods", "1", "--no-plot"], []),
    ("--x0 x1=1e308", {}, ["hybrid", "simulate", "absorber", "--x0", "x1=1e308", "--periods", "1", "--no-plot"], []),
    ("grazing guard sign(v) in periodic_orbit", {}, [PY, "-c", _lib("from hybrid import HybridSystem, Mode, Transition\nrhs = {'x': 'v', 'v': '-x - 0.1*v + cos(W*t)'}\ns = HybridSystem(name='relay', variables=['x', 'v'], parameters=['W'], modes=[Mode('up', derivatives=rhs), Mode('down', derivatives=rhs)], transitions=[Transition('up', 'down', guard='sign(v)', direction=-1, name='fall'), Transition('down', 'up', guard='sign(v)', direction=1, name='rise')], period='2*pi/W', initial_mode='up')\nprint(hybrid.periodic_orbit(s, {'W': 1.3}, {'x': 0.0, 'v': 0.5}, 'up').message)")], []),
    ("t_span near 1e17", {}, [PY, "-c", _lib("s = hybrid_models.coulomb()\np = s.preset('forced')\nprint(hybrid.simulate(s, p, (1e17, 1e17 + 1e3), {'x': 0, 'v': 0}, throw=False).message)")], []),
    ("--out existing file (frc)", {"f.txt": "keep"}, ["hybrid", "frc", "absorber", "--out", "f.txt"], []),
    ("--out /dev/null", {}, ["hybrid", "simulate", "absorber", "--out", "/dev/null"], []),
    ("--out unwritable", {"f.txt": "keep"}, ["hybrid", "orbit", "absorber", "--out", "f.txt/sub"], []),
    ("--out ''", {}, ["hybrid", "simulate", "absorber", "--out", ""], []),
    ("frc --omega-range 0.001 1000", {}, ["hybrid", "frc", "absorber", "--omega-range", "0.001", "1000", "--no-plot"], []),
    ("orbit --transient 1000000", {}, ["hybrid", "orbit", "absorber", "--transient", "1000000", "--no-plot"], []),
    ("simulate m1 = m2 = 1e-9", {}, ["hybrid", "simulate", "absorber", "--set", "m1=1e-9", "--set", "m2=1e-9", "--no-plot"], []),
    ("orbit m2 = 1e-9", {}, ["hybrid", "orbit", "absorber", "--set", "m2=1e-9", "--no-plot"], []),
    ("orbit --samples-per-period 1e8", {}, ["hybrid", "orbit", "absorber", "--samples-per-period", "100000000"], []),
    ("simulate --periods 10000", {}, ["hybrid", "simulate", "absorber", "--omega", "0.854", "--periods", "10000"], []),
    ("t_span (1e15, 1e15 + T)", {}, [PY, "-c", _lib("s = hybrid_models.coulomb()\np = s.preset('forced')\ntr = hybrid.simulate(s, p, (1e15, 1e15 + 7.85), {'x': 1, 'v': 0}, throw=False)\nprint(tr.status.name, tr.message)")], []),
    ("model without a period, long span", {"m.toml": _coulomb(**{'period = "2*pi/Omega"\n': ""})}, ["hybrid", "simulate", "m.toml", "--preset", "forced", "--t-end", "60000000", "--no-plot"], []),
    ("periodic_orbit(settings=ShootingOptions(samples_per_period=0))", {}, [PY, "-c", _lib("s = hybrid_models.absorber()\nprint(hybrid.periodic_orbit(s, s.preset('standard', Omega=0.854), settings=hybrid.ShootingOptions(samples_per_period=0)).amplitude['x1'])")], []),
    ("cond(I - M) of a fully stuck orbit", {}, [PY, "-c", _lib("s = hybrid_models.coulomb()\no = hybrid.periodic_orbit(s, s.preset('free'))\nprint(o.condition, o.message)")], []),
    ("progress callback raises", {}, [PY, "-c", "import hybrid_models, hybrid\ns = hybrid_models.coulomb()\ndef cb(f): raise KeyError('mine')\ntry:\n    hybrid.simulate(s, s.preset('forced'), (0, 10), {'x': 0, 'v': 0}, progress=cb, throw=False)\nexcept KeyError as e:\n    print('propagated', e)"], []),
    ("orbit at the stick resonance 0.8543090", {}, ["hybrid", "orbit", "absorber", "--omega", "0.8543090", "--no-plot"], []),
    ("F = 100 N", {}, ["hybrid", "simulate", "absorber", "--set", "F=100", "--periods", "5", "--no-plot"], []),
    ("c3 = 1e9", {}, ["hybrid", "simulate", "absorber", "--set", "c3=1e9", "--periods", "5", "--no-plot"], []),
    ("--omega 1e308", {}, ["hybrid", "simulate", "absorber", "--omega", "1e308", "--no-plot"], []),
    ("symlink to /dev/zero", {"z.toml": "->/dev/zero"}, ["hybrid", "simulate", "z.toml"], []),
    ("UTF-8 BOM", {"m.toml": "\ufeff" + COULOMB}, ["hybrid", "simulate", "m.toml", "--preset", "forced", "--periods", "1", "--no-plot"], []),
    ("removed key stick_modes", {"m.toml": _coulomb(**{'gauge = "': 'stick_modes = 5\ngauge = "'})}, ["hybrid", "simulate", "m.toml"], []),
    ("definitions nest too deeply (100-level chain)", {"m.toml": _definitions("".join(f'c{k} = "{"x" if k == 0 else f"c{k - 1} + 0*x"}"\n' for k in range(100)))}, ["hybrid", "simulate", "m.toml", "--preset", "forced", "--periods", "1", "--no-plot"], []),
    ("variable name with a newline", {"m.toml": _coulomb(**{"[variables.x]": '[variables."x\\n"]'})}, ["hybrid", "simulate", "m.toml"], []),
    ("unknown [plot] key", {"m.toml": _coulomb(**{'force = "friction"': 'forse = "friction"'})}, ["hybrid", "simulate", "m.toml"], []),
    ("R = 0 at the slip resonance", {}, ["hybrid", "orbit", "absorber", "--set", "R=0", "--omega", "0.8525006", "--no-plot"], []),
]  # fmt: skip


def run_case(label, files, argv, forbidden, timeout) -> dict:
    work = Path(tempfile.mkdtemp(prefix="hostile-"))
    try:
        for name, content in files.items():
            path = work / name
            if content is None:
                with path.open("wb") as fh:
                    fh.truncate(2 << 30)
            elif isinstance(content, str) and content.startswith("->"):
                os.symlink(content[2:], path)
            else:
                path.write_text(content, encoding="utf-8")
        cmd = ["/usr/bin/time", "-f", "TIME %e %M", *argv]
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, cwd=work, capture_output=True, text=True, timeout=timeout)
            code, err, out = p.returncode, p.stderr, p.stdout
        except subprocess.TimeoutExpired as exc:
            code, err, out = "killed", (exc.stderr or b"").decode(errors="replace"), ""
        wall = time.perf_counter() - t0
        peak = ""
        lines = []
        for line in err.splitlines():
            if line.startswith("TIME "):
                peak = f"{int(line.split()[2]) / 1024:.0f}"
            elif (
                line.strip()
                and not line.startswith(("model `", "continuation in", "wrote ", "\r", "note: ", "  "))
                and "Warning" not in line
            ):
                lines.append(line.strip())
        if not lines:
            lines = [s.strip() for s in out.splitlines() if s.strip()]
        first = lines[0] if lines else ""
        if any("Traceback" in s for s in err.splitlines()):
            first = "TRACEBACK: " + (err.strip().splitlines()[-1] if err.strip() else "")
        escaped = [f for f in forbidden if (work / f).exists() or Path(f).is_absolute() and Path(f).exists()]
        return {"case": label, "exit": code, "first line": first[:160], "wall [s]": f"{wall:.1f}",
                "peak [MB]": peak, "escaped": ", ".join(escaped)}  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="run the cases whose label contains this text")
    ap.add_argument("--timeout", type=float, default=1200.0, help="kill a case after this many seconds")
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()}")
    print("| case | exit | first line | wall [s] | peak [MB] |")
    print("|---|---|---|---|---|")
    for label, files, argv, forbidden in CASES:
        if args.only and args.only not in label:
            continue
        r = run_case(label, files, argv, forbidden, args.timeout)
        first = r["first line"].replace("|", "\\|")
        esc = f" ESCAPED: {r['escaped']}" if r["escaped"] else ""
        print(
            f"| {r['case']} | {r['exit']} | {first}{esc} | {r['wall [s]']} | {r['peak [MB]']} |", flush=True
        )


if __name__ == "__main__":
    main()
