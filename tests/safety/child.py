"""Running one campaign case's child process: its own process group, a signal sent after
a while when the case asks for one, a timeout after which the whole group is killed."""
from __future__ import annotations

import os
import signal
import subprocess
from dataclasses import dataclass


@dataclass
class Ran:
    """What a child did: exit status (None when it hung), its output, whether it hung, and
    its process id (its process group's, to kill what it may have left running)."""

    rc: int | None
    out: str
    err: str
    hang: bool
    pid: int


def run_child(cmd: list[str], *, timeout: float, signal_after: tuple[int, float] | None = None,
              **popen) -> Ran:
    """Run ``cmd`` to its end or ``timeout`` seconds; ``signal_after=(SIG, SECONDS)`` sends
    SIG to its process group after SECONDS when it still runs. The child must lead its own
    process group (``start_new_session=True``, or ``os.setsid()`` in ``preexec_fn``): a
    hung one is killed with everything it started."""
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace", **popen)
    try:
        if signal_after:
            sig, after = signal_after
            try:
                p.wait(timeout=after)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, sig)
        out, err = p.communicate(timeout=timeout)
        return Ran(p.returncode, out, err, False, p.pid)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        return Ran(None, out, err, True, p.pid)


def case_command(python: str, script: str | None, argv: list[str] | None, d: str) -> list[str]:
    """The child's command line: a Python snippet run with the case folder as its argument,
    or the ``puppet`` command with ``{d}`` in its arguments replaced by the case folder."""
    if script is not None:
        return [python, "-c", script, d]
    return [python, "-m", "puppet", *[a.replace("{d}", d) for a in argv]]
