"""A signal at any point of an export ends it promptly (issue 20, "never hang").

The signal's exception lands in the calling thread wherever it is; a stage thread may
then be blocked for ever (on a lock the exception left taken, say). The pipeline must
not wait on it without a bound, must not leave a stage running that it started, and the
signal-holding block of :mod:`puppet.output` must give the signals back whatever happens.
"""
from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

from puppet import output
from puppet.anim import pipeline
from tests.conftest import ROOT

# A process whose SIGUSR1 raises Stopped (like the CLI's SIGTERM/SIGHUP) 0.5 s into an
# export whose stage STAGE blocks for ever; it prints the seconds from signal to return.
_SCRIPT = textwrap.dedent("""
    import os, signal, sys, threading, time
    import numpy as np
    from puppet.anim import pipeline

    pipeline.HALT_TIMEOUT = 1.0
    STAGE = sys.argv[1]
    never = threading.Event()
    frame = np.zeros((4, 4, 4), np.uint8)

    class Stopped(BaseException):
        pass

    sent = []
    def on_signal(signum, _):
        signal.signal(signum, signal.SIG_IGN)
        raise Stopped

    signal.signal(signal.SIGUSR1, on_signal)

    def solve(i):
        if STAGE == "solve" and i == 3:
            never.wait()
        return i

    def add(rgba):
        if STAGE == "encode":
            never.wait()

    def kill():
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGUSR1)
    threading.Timer(0.5, kill).start()
    try:
        pipeline.run(pipeline.frames(solve, lambda i: frame, list(range(1000))), add)
    except Stopped:
        print(f"stopped {time.monotonic() - sent[0]:.2f}")
""")


@pytest.mark.parametrize("stage", ["encode", "solve"])
def test_signal_while_a_stage_is_blocked_ends_promptly(stage):
    """Old code: the cleanup joined the blocked thread without a bound and never returned."""
    try:
        r = subprocess.run([sys.executable, "-c", _SCRIPT, stage], capture_output=True, text=True,
                           timeout=30, cwd=ROOT, env={"PYTHONPATH": ROOT, "PATH": "/usr/bin:/bin"})
    except subprocess.TimeoutExpired:
        pytest.fail(f"the export with a blocked {stage} stage did not end within 30 s of the signal")
    assert r.returncode == 0, r.stderr
    word, seconds = r.stdout.split()
    assert word == "stopped" and float(seconds) < 1.0 + 5.0, r.stdout  # HALT_TIMEOUT + slack


class _Signal(BaseException):
    """What a signal handler raises (the CLI's Stopped, KeyboardInterrupt)."""


def _stage_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name in ("puppet-solve", "puppet-encode") and t.is_alive()]


@pytest.mark.parametrize("which", ["puppet-solve", "puppet-encode"])
def test_signal_right_after_a_stage_starts_leaves_no_thread(monkeypatch, which):
    """The signal lands just as ``start()`` returns: that stage is stopped too (old code: it
    ran on for ever, the solver solving ahead into a full queue)."""
    assert not _stage_threads()
    start = pipeline._StageThread.start

    def start_then_signal(self):
        start(self)
        if self.name == which:
            raise _Signal
    monkeypatch.setattr(pipeline._StageThread, "start", start_then_signal)
    frame = np.zeros((4, 4, 4), np.uint8)
    with pytest.raises(_Signal):
        pipeline.run(pipeline.frames(lambda i: i, lambda i: frame, list(range(1000))), lambda rgba: None)
    end = time.monotonic() + 5.0
    while _stage_threads() and time.monotonic() < end:
        time.sleep(0.02)
    assert not _stage_threads()


def _blocked() -> set[int]:
    return set(signal.pthread_sigmask(signal.SIG_BLOCK, ())) & output._SIGNALS


def test_signals_given_back_when_the_blocking_call_raises(monkeypatch):
    """``pthread_sigmask`` runs a pending handler after blocking; its exception must not
    leave SIGINT/SIGTERM/SIGHUP blocked (the CLI's own kill would then not end the process)."""
    real = signal.pthread_sigmask
    before = real(signal.SIG_BLOCK, ())

    def pending_handler_runs(how, mask):
        old = real(how, mask)
        if how == signal.SIG_BLOCK and set(mask) == output._SIGNALS:
            raise _Signal  # as the handler of a signal that came just before would
        return old
    monkeypatch.setattr(output.signal, "pthread_sigmask", pending_handler_runs)
    try:
        with pytest.raises(_Signal):
            with output._signals_blocked():
                pytest.fail("the block must not run")
        assert not _blocked()
    finally:
        real(signal.SIG_SETMASK, before)
