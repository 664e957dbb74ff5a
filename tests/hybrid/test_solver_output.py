"""SUNDIALS' messages kept off stdout without taking stdout from the program's threads (issue 29,
item 4; hybrid/integrators/solver_output.py).

The defect: every call into IDA did ``saved, sys.stdout = sys.stdout, notes`` and put ``saved``
back after. Two threads running IDA at once interleave those: the second saves the first one's
``notes`` and puts it back last, so ``sys.stdout`` stays a sink and everything the program prints
afterwards vanishes (exit code 0).
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest

from hybrid.integrators.solver_output import StdoutRouter, kept_prints

ROOT = Path(__file__).resolve().parents[2]
REPS = 20

# Two threads run the same IDA simulation at once, REPS times; each prints its final state after its
# run, and the main thread a line after both. One of them has IDA stop after 2 internal steps per call,
# so that SUNDIALS prints "mxstep steps taken before reaching tout" at every call (kept off stdout),
# and the run goes on to the same end. The reference: the same run alone, before any thread.
SCRIPT = textwrap.dedent(
    f"""
    import math, sys, threading
    import hybrid, hybrid_models
    from hybrid import IDA, SolverOptions

    system = hybrid_models.coulomb()
    p = system.preset("forced")
    T = 2 * math.pi / p["Omega"]
    x0 = dict.fromkeys(system.variable_names, 0.0)
    options = (SolverOptions(method=IDA()), SolverOptions(method=IDA(max_num_steps=2)))

    def final(k):
        tr = hybrid.simulate(system, p, (0.0, T), x0, options=options[k])
        return f"{{tr.success}} {{tr.mode_final}} {{tr.y_final.tolist()}}"

    print("reference", final(0), flush=True)
    sys.setswitchinterval(1e-6)  # threads switch inside IDA's callbacks, i.e. inside the calls

    def run(rep, k):
        line = f"rep {{rep}} thread {{k}} {{final(k)}}"
        print(line + "\\n", end="")  # one write: the lines of two threads do not interleave

    for rep in range({REPS}):
        threads = [threading.Thread(target=run, args=(rep, k)) for k in range(2)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        print(f"rep {{rep}} joined")
    """
)


@pytest.mark.slow
def test_threads_running_ida_keep_the_programs_output():
    # issue 29, item 4: before, the program's lines after concurrent IDA runs vanished (2 of 3
    # runs of two threads; 0 of these REPS repetitions printed)
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=300, cwd=ROOT, check=False
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("reference True "), proc.stdout
    reference = lines[0].removeprefix("reference ")
    expected = {f"rep {rep} thread {k} {reference}" for rep in range(REPS) for k in range(2)}
    expected |= {f"rep {rep} joined" for rep in range(REPS)}
    # every line once, each thread's result equal to the run alone (the other thread's run and
    # messages changed nothing), and nothing else: no SUNDIALS message on stdout
    assert sorted(lines[1:]) == sorted(expected), proc.stdout
    assert "mxstep" not in proc.stdout


def _solver(started: threading.Event, go_on: threading.Event, out: dict, text: str) -> threading.Thread:
    """A thread that prints ``text`` as a solver would inside :func:`kept_prints`, then waits."""

    def body():
        with kept_prints() as kept:
            print(f"\n[IDASolve, Error: -1] {text}\n")
            started.set()
            go_on.wait(10)
        out[text] = kept.text

    return threading.Thread(target=body)


def test_another_threads_output_goes_through_while_a_solver_runs(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stdout", stream)
    started, go_on, out = threading.Event(), threading.Event(), {}
    words = "At t = 1, mxstep steps taken before reaching tout."
    th = _solver(started, go_on, out, words)
    th.start()
    assert started.wait(10)
    print("the program's line")  # while the solver's thread is inside
    assert stream.getvalue() == "the program's line\n"  # at once, not held back
    go_on.set()
    th.join()
    assert sys.stdout is stream
    assert stream.getvalue() == "the program's line\n"
    assert out == {words: words}  # its own words, the "[IDASolve, Error: -1]" tag removed


def test_overlapping_solver_threads_put_the_stream_back_and_keep_their_own_words(monkeypatch):
    # the interleaving that lost the output: A enters, B enters, A leaves, B leaves
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stdout", stream)
    events = [(threading.Event(), threading.Event()) for _ in range(2)]
    out: dict = {}
    threads = [_solver(s, g, out, f"words of {k}") for k, (s, g) in enumerate(events)]
    for th, (started, _) in zip(threads, events, strict=True):
        th.start()
        assert started.wait(10)
    assert isinstance(sys.stdout, StdoutRouter)
    for th, (_, go_on) in zip(threads, events, strict=True):
        go_on.set()
        th.join()
    assert sys.stdout is stream
    assert stream.getvalue() == ""
    assert out == {"words of 0": "words of 0", "words of 1": "words of 1"}


def test_a_stream_the_program_sets_meanwhile_stays(monkeypatch):
    stream, theirs = io.StringIO(), io.StringIO()
    monkeypatch.setattr(sys, "stdout", stream)
    with kept_prints() as kept:
        router = sys.stdout
        sys.stdout = theirs
        print("to theirs")
    assert sys.stdout is theirs
    assert theirs.getvalue() == "to theirs\n"
    assert kept.text == ""
    router.write("through a router kept by reference\n")  # outside: on to the stream it replaced
    assert stream.getvalue() == "through a router kept by reference\n"


def test_nested_blocks_keep_their_own_words_and_put_the_stream_back(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stdout", stream)
    with kept_prints() as outer:
        assert sys.stdout.getvalue() == ""  # every other attribute is the replaced stream's
        print("outer first")
        with kept_prints() as inner:
            print("[IDASolve, Error: -3] inner")
        print("outer last")
    assert (outer.text, inner.text) == ("outer last", "inner")
    assert sys.stdout is stream
    assert stream.getvalue() == ""
    with pytest.raises(RuntimeError, match="inside"), kept_prints():
        raise RuntimeError("inside")
    assert sys.stdout is stream


def test_printing_while_solver_threads_come_and_go(monkeypatch):
    # one thread enters and leaves kept_prints over and over while another prints: every line
    # arrives, and no router is freed under a print (a segmentation fault with a router made per
    # entry: the built-in print of CPython 3.11 holds sys.stdout without a reference of its own)
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stdout", stream)
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:

        def solver():
            for _ in range(2000):
                with kept_prints():
                    print("solver words")

        def program():
            for i in range(2000):
                print(f"line {i}")

        threads = [threading.Thread(target=solver), threading.Thread(target=program)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
    finally:
        sys.setswitchinterval(interval)
    assert sys.stdout is stream
    assert stream.getvalue().splitlines() == [f"line {i}" for i in range(2000)]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_process_forked_while_another_thread_is_inside_gets_its_stream_back(monkeypatch):
    # the child has only the forking thread: the other one's entry must not keep the router in
    # place there, nor a lock it might have held block the child's own calls
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stdout", stream)
    started, go_on, out = threading.Event(), threading.Event(), {}
    th = _solver(started, go_on, out, "words")
    th.start()
    assert started.wait(10)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: report, never return into pytest
        code = 1
        try:
            restored = sys.stdout is stream
            with kept_prints() as kept:
                print("child words")
            code = 0 if restored and sys.stdout is stream and kept.text == "child words" else 2
        finally:
            os.write(write, bytes([code]))
            os._exit(0)
    os.close(write)
    status = os.read(read, 1)
    os.close(read)
    os.waitpid(pid, 0)
    go_on.set()
    th.join()
    assert status == bytes([0])
    assert sys.stdout is stream
