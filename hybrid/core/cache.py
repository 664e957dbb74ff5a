"""Explicit caches: what is derived from an immutable object and kept with it, and bounded LRU maps.

A :class:`hybrid.HybridSystem` is frozen: its fields never change after construction. What the
engine derives from it (its compiled forms, the exact integrator's analysis, compiled gauges) is
kept in one :class:`DerivedCache` made with the system, under keys owned by the modules that
derive them, each value made once on first use. Nothing is written into an object's
``__dict__`` after construction: what an object makes from its own data on first use is a field
declared with the object (one value, or an :class:`LRUCache` of a stated size), filled by the
object's own methods, and module-level caches are :class:`LRUCache` objects of a stated size.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

from .errors import InputError

__all__ = ["DerivedCache", "LRUCache"]

_MISSING = object()


class DerivedCache:
    """Values derived from one object, by key, each made once (thread-safe).

    Parameters
    ----------
    limit : int
        Most keys it holds (the keys are a fixed set named by the modules that use it, so the
        limit only catches a key made of data by mistake).
    """

    def __init__(self, limit: int = 32):
        self._values: dict[Hashable, Any] = {}
        self._limit = limit
        self._lock = threading.RLock()

    def get(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """The value under ``key``, made by ``make()`` on first use."""
        with self._lock:
            if key not in self._values:
                if len(self._values) >= self._limit:
                    raise InputError(f"DerivedCache: more than {self._limit} keys (a key made of data?)")
                self._values[key] = make()
            return self._values[key]

    def __contains__(self, key: Hashable) -> bool:
        return key in self._values

    def __repr__(self) -> str:
        return f"DerivedCache({sorted(map(str, self._values))})"


class LRUCache:
    """A mapping of at most ``size`` entries; the least recently used goes first (thread-safe).

    Parameters
    ----------
    size : int
        Most entries kept.
    """

    def __init__(self, size: int):
        if size < 1:
            raise InputError(f"LRUCache: `size` must be >= 1, got {size!r}")
        self.size = size
        self._data: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable, default: Any = None) -> Any:
        """The value under ``key`` (now the most recent), or ``default``."""
        with self._lock:
            if key not in self._data:
                return default
            self._data.move_to_end(key)
            return self._data[key]

    def put(self, key: Hashable, value: Any) -> None:
        """Keep ``value`` under ``key`` (the most recent), dropping the least recent beyond ``size``."""
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.size:
                self._data.popitem(last=False)

    def get_or_make(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """The value under ``key`` (now the most recent), made by ``make()`` and kept if absent.

        ``make`` runs outside the lock (two threads may both make a missing value; the last kept
        wins, and each gets the one it made or found)."""
        hit = self.get(key, _MISSING)
        if hit is _MISSING:
            hit = make()
            self.put(key, hit)
        return hit

    def __len__(self) -> int:
        return len(self._data)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._data
