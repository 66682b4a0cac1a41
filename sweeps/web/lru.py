"""The one cache of the web view (as xarray keeps one ``LRUCache`` behind every cache of
open files): the most recently used entries, at most ``size`` of them by weight (each
entry weighs 1 unless ``weight`` says otherwise: a map's bytes). The last entry put is kept
whatever it weighs. Thread-safe: the pages read it from the executor's threads."""
from __future__ import annotations

import threading
from collections import OrderedDict


class LRU:
    def __init__(self, size: int, weight=None):
        self.size = size
        self._weight = weight or (lambda value: 1)
        self._data: OrderedDict = OrderedDict()
        self._total = 0
        self._lock = threading.Lock()

    def get(self, key, default=None):
        """The entry of ``key`` (now the most recent), or ``default``."""
        with self._lock:
            if key not in self._data:
                return default
            self._data.move_to_end(key)
            return self._data[key]

    def put(self, key, value) -> None:
        with self._lock:
            if key in self._data:
                self._total -= self._weight(self._data.pop(key))
            self._data[key] = value
            self._total += self._weight(value)
            while self._total > self.size and len(self._data) > 1:
                self._total -= self._weight(self._data.popitem(last=False)[1])

    def pop(self, key, default=None):
        with self._lock:
            if key not in self._data:
                return default
            value = self._data.pop(key)
            self._total -= self._weight(value)
            return value

    def clear(self) -> None:
        with self._lock:
            self._data.clear()
            self._total = 0

    def __contains__(self, key) -> bool:
        with self._lock:
            return key in self._data

    def __len__(self) -> int:
        with self._lock:
            return len(self._data)
