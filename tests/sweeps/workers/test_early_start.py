"""sweeps.workers.cluster.EarlyStart: Ctrl-C is ignored while the workers are being born
(they inherit it) and given back once they are up, whether the main thread waits in
``client`` or computes blocks meanwhile and asks ``ready`` (sweeps.run.head_start): a
first compile on the workers takes a minute, and a Ctrl-C then must stop the run. Here
with a stand-in for the cluster's start, which the test lets through step by step."""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

from sweeps.workers.cluster import EarlyStart


def test_ready_gives_ctrl_c_back_once_the_workers_are_up_and_says_when_warm():
    born, warm = threading.Event(), threading.Event()

    class Client:
        def run(self, fn, *args):   # (dask's: fn on every worker)
            return fn(*args)

    @contextmanager
    def connect():
        born.wait(60)   # the workers being started
        yield Client()

    def warm_up():
        warm.wait(60)   # their warm-up (a first compile)

    before = signal.getsignal(signal.SIGINT)
    early = EarlyStart(connect(), (warm_up,))
    try:
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert not early.ready() and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        born.set()
        early._up.wait(60)
        assert not early.ready()   # warming up: not ready, but Ctrl-C is back
        assert signal.getsignal(signal.SIGINT) is before
        warm.set()
        early._thread.join(60)
        assert early.ready()
    finally:
        born.set()
        warm.set()
        early._thread.join(60)
        signal.signal(signal.SIGINT, before)
