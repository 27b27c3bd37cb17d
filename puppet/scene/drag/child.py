"""A child ``python`` on one end of a socket pair: the solver processes' plumbing
(:class:`puppet.scene.drag.process.DragProcess`, :class:`puppet.anim.solver.ProcessSolver`).

A fresh interpreter rather than ``multiprocessing``: no GL state is inherited, and the
caller's main script is not imported again there (a script without an ``if __name__ ==
"__main__"`` guard is safe). The child finds this ``puppet`` first on its path.
"""
from __future__ import annotations

import os
import sys


def start_child(module: str, function: str, env: dict | None = None):
    """Run ``module.function(fd)`` in a child ``python``; returns ``(Popen, Connection)``
    (``env``: variables added to this process's environment). Raises OSError when the
    child cannot be started."""
    import socket
    import subprocess
    from multiprocessing.connection import Connection

    mine, theirs = socket.socketpair()
    env = dict(os.environ, **(env or {}))
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), *[os.pardir] * 3))  # above puppet/
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
    code = f"from {module} import {function}; {function}({theirs.fileno()})"
    try:
        proc = subprocess.Popen([sys.executable, "-c", code], pass_fds=(theirs.fileno(),), env=env,
                                stdin=subprocess.DEVNULL, close_fds=True)
    except OSError:
        mine.close()
        raise
    finally:
        theirs.close()
    return proc, Connection(mine.detach())


def child_setup(fd: int):
    """In the child: Ctrl-C left to the parent, stdout onto stderr; the Connection."""
    import signal
    from multiprocessing.connection import Connection

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent decides
    os.dup2(2, 1)  # nothing may print on stdout
    return Connection(fd)


def messages(conn):
    """In the child: the parent's messages, until it sends ``None`` or the pipe closes."""
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        yield msg


def stop_child(proc, conn) -> None:
    """Ask the child to stop (``None``), wait 2 s, then kill it; close the connection."""
    import subprocess

    try:
        conn.send(None)
    except (OSError, ValueError):
        pass
    try:
        proc.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    conn.close()
