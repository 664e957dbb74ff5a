"""The one worker mechanism of frequency responses and sweeps (issue 29 item 5):
hybrid.core.workers.ProcessPool, its messages, and run_calls."""

from __future__ import annotations

import multiprocessing
import os
import pickle
import struct
import time
from concurrent.futures import ThreadPoolExecutor

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from hybrid.core.errors import WorkerError
from hybrid.core.threads import BLAS_THREADS_ENV
from hybrid.core.workers import ProcessPool, _Channel, run_calls, send

pytestmark = pytest.mark.skipif(
    "fork" not in multiprocessing.get_all_start_methods(), reason="messages need forked workers"
)


def _reporter(i: int, n: int) -> int:
    """A task: ``n`` messages ``(i, k)``, then ``i * i``."""
    for k in range(n):
        send((i, k))
    return i * i


def _big(n: int) -> int:
    send(b"x" * n)
    return n


def _slow(i: int) -> int:
    time.sleep(0.2)
    return i


def _blas_threads() -> list[int]:
    return [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"]


def test_each_calls_messages_come_in_order_and_before_its_result():
    got: dict[int, list[int]] = {}
    results: dict[int, int] = {}

    def on_result(i, value):
        assert got.get(i, []) == list(range(3 * i))  # all its messages, in the order sent, first
        results[i] = value

    with ProcessPool(2) as pool:
        left = run_calls(
            pool,
            _reporter,
            [(i, 3 * i) for i in range(6)],
            on_result=on_result,
            on_error=lambda i, exc: pytest.fail(f"call {i}: {exc!r}"),
            on_message=lambda m: got.setdefault(m[0], []).append(m[1]),
        )
    assert left == []
    assert results == {i: i * i for i in range(6)}


def test_a_message_larger_than_the_pipe_arrives_whole():
    seen = []
    with ProcessPool(1) as pool:
        run_calls(
            pool,
            _big,
            [(3_000_000,)],
            on_result=lambda i, v: seen.append(v),
            on_error=lambda i, exc: pytest.fail(repr(exc)),
            on_message=seen.append,
        )
    assert seen == [b"x" * 3_000_000, 3_000_000]


def test_a_half_written_message_never_blocks_the_reader():
    """A worker killed while writing leaves part of a message in the pipe: the parent must go on
    (the pool is ending), not wait for the rest."""
    ch = _Channel(multiprocessing.get_context("fork"))
    try:
        data = pickle.dumps(("point", 1, 2))
        frame = struct.pack("!Q", len(data)) + data
        os.write(ch.write_fd, frame + frame[:5])  # one whole message and the start of another
        assert ch.get_all(0.1) == [("point", 1, 2)]
        assert ch.get_all(0.1) == []  # (a blocking read would never return)
        os.write(ch.write_fd, frame[5:])
        assert ch.get_all(0.1) == [("point", 1, 2)]
    finally:
        ch.close()


def test_stop_ends_the_run_with_the_calls_not_handed_over_and_withdraws_them():
    handed = []
    with ProcessPool(1) as pool:
        left = run_calls(
            pool,
            _slow,
            [(i,) for i in range(5)],
            on_result=lambda i, v: handed.append(i),
            on_error=lambda i, exc: pytest.fail(repr(exc)),
            stop=lambda: bool(handed),  # once the first result is handed over
        )
        pool.kill()
    assert handed == [0]
    assert left == [1, 2, 3, 4]


def test_a_pool_task_runs_with_one_blas_thread(monkeypatch):
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can see")
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    out = []
    with threadpool_limits(limits=2, user_api="blas"), ProcessPool(1) as pool:  # the parent: 2
        run_calls(
            pool,
            _blas_threads,
            [()],
            on_result=lambda i, v: out.append(v),
            on_error=lambda i, exc: pytest.fail(repr(exc)),
        )
    assert out and set(out[0]) == {1}


def test_messages_need_a_forked_pool_and_a_worker():
    with ThreadPoolExecutor(1) as ex, pytest.raises(TypeError, match="needs a forked ProcessPool"):
        run_calls(ex, abs, [(1,)], on_result=print, on_error=print, on_message=print)
    with pytest.raises(WorkerError, match="outside a worker of a forked ProcessPool"):
        send("hello")
