"""Imported by each worker process of the embedded cluster when it starts (a Dask preload).

Ctrl+C in a terminal reaches every process of the foreground group: the workers ignore
it, and the client stops the batch and closes the cluster itself (no traceback from
each worker, no job cut half way by its own process).
"""
from __future__ import annotations

import os
import signal
import threading


def dask_setup(worker) -> None:
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    # a worker given one core's share (as many workers as cores) solves on one thread too:
    # the factorisation's and the two coordinates' second thread would only contend
    if os.environ.get("LP_NUM_THREADS") in ("0", "1"):
        from puppet.deform import factor  # lazy: a worker's preload; numpy comes with its first job

        factor.THREADS = False
