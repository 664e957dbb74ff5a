"""BLAS threads while the engine computes (hybrid/core/threads.py)."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from hybrid.core.errors import InputError
from hybrid.core.threads import BLAS_THREADS_ENV, blas_threads


def _blas_threads() -> list[int]:
    return [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"]


@pytest.fixture
def two_threads():
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can see")
    with threadpool_limits(limits=2, user_api="blas"):
        yield


def test_blas_runs_on_one_thread_inside_and_as_before_after(two_threads, monkeypatch):
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    before = _blas_threads()
    with blas_threads():
        assert set(_blas_threads()) == {1}
        with blas_threads():  # nested: still one, and the outer exit restores
            assert set(_blas_threads()) == {1}
        assert set(_blas_threads()) == {1}
    assert _blas_threads() == before


def test_the_environment_sets_the_threads_or_leaves_them(two_threads, monkeypatch):
    before = _blas_threads()
    monkeypatch.setenv(BLAS_THREADS_ENV, "0")
    with blas_threads():
        assert _blas_threads() == before
    monkeypatch.setenv(BLAS_THREADS_ENV, "2")
    with blas_threads():
        assert set(_blas_threads()) == {2}


@pytest.mark.parametrize("text", ["-1", "many"])
def test_a_bad_setting_names_the_variable(monkeypatch, text):
    monkeypatch.setenv(BLAS_THREADS_ENV, text)
    with pytest.raises(InputError, match=BLAS_THREADS_ENV), blas_threads():
        pass


def test_a_blas_library_loaded_after_the_first_limit_is_limited_too(two_threads, monkeypatch):
    """scikit-sundae brings its own OpenBLAS, loaded with the first IDA run: a controller made before
    it (an exact run first) must not leave it unlimited. Simulated by a controller that knows only
    one of the libraries loaded now, made before the last import."""
    import sys

    from threadpoolctl import ThreadpoolController

    import hybrid.core.threads as threads

    if len(_blas_threads()) < 2:
        pytest.skip("one BLAS library loaded: nothing can be missed")
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    stale = ThreadpoolController()
    stale.lib_controllers = stale.lib_controllers[:1]
    monkeypatch.setattr(threads, "_controller", stale)
    monkeypatch.setattr(threads, "_modules", len(sys.modules) - 1)  # a module imported since
    with blas_threads():
        assert set(_blas_threads()) == {1}  # every library, not only the one the stale controller knew
    fresh = threads._get_controller()
    assert fresh is not stale
    assert threads._get_controller() is fresh  # no import since: kept
