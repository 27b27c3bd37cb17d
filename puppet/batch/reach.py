"""Is ``--scheduler`` a Dask scheduler that answers? Checked before Dask is asked to connect,
so that every way of failing is one line within a deadline (Dask's own client waits for ever
on a server that accepts and never answers, and allocates whatever length a garbage answer
announces).

1. The address: ``tcp://HOST:PORT``, ``tls://HOST:PORT`` or ``HOST:PORT`` (port 1..65535);
   anything else (``''``, ``inproc://``, ``ucx://``, text) is refused by its form.
2. A TCP connection within :data:`CONNECT_SECONDS` (refused, unroutable, unknown host: one line).
3. For ``tcp://``: the server's first message within :data:`CONNECT_SECONDS`, checked to be
   the handshake a Dask scheduler sends on every new connection (a little framed msgpack
   map naming ``python`` and ``compression``): a silent server or another protocol is refused.
"""
from __future__ import annotations

import re
import socket
import struct
import time

from puppet.errors import SceneError

#: Seconds allowed for each step of reaching a scheduler (connect, its first answer, Dask's client).
CONNECT_SECONDS = 5.0
#: Largest handshake accepted from a scheduler (bytes; Dask's is ~60).
MAX_HANDSHAKE = 64 * 1024

_ADDRESS = re.compile(r"(?:(?P<scheme>[a-z]+)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>\d{1,5})")


def _fail(scheduler: str, why: str) -> SceneError:
    return SceneError(f"--scheduler {scheduler!r}: {why}")


def parse_address(scheduler: str) -> tuple[str, str, int]:
    """(scheme, host, port) of a scheduler address; SceneError for any other form."""
    m = _ADDRESS.fullmatch(scheduler.strip())
    if m is None:
        raise _fail(scheduler, "not a scheduler address; give tcp://HOST:PORT (or tls://HOST:PORT)")
    scheme = m.group("scheme") or "tcp"
    if scheme not in ("tcp", "tls"):
        raise _fail(scheduler, f"{scheme}:// is not supported; give tcp://HOST:PORT (or tls://HOST:PORT)")
    port = int(m.group("port"))
    if not 1 <= port <= 65535:
        raise _fail(scheduler, f"port {port} is not a port (1..65535)")
    return scheme, m.group("host").strip("[]"), port


def check_scheduler(scheduler: str, *, seconds: float = CONNECT_SECONDS) -> str:
    """The address to give Dask, once the scheduler was reached and (tcp) answered like one.

    Raises
    ------
    SceneError
        One line: a malformed address, no connection, no answer or not a Dask scheduler.
    """
    scheme, host, port = parse_address(scheduler)
    try:
        sock = socket.create_connection((host, port), timeout=seconds)
    except socket.timeout:
        raise _fail(scheduler, f"no connection within {seconds:g} s") from None
    except OSError as e:
        raise _fail(scheduler, f"cannot connect ({e.strerror or e})") from None
    with sock:
        if scheme == "tcp":
            _handshake(sock, scheduler, seconds)
    return f"{scheme}://{host if ':' not in host else f'[{host}]'}:{port}"


def _read(sock: socket.socket, n: int, deadline: float, scheduler: str) -> bytes:
    data = b""
    while len(data) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise _fail(scheduler, "accepts connections but does not answer like a Dask scheduler "
                        f"(nothing within {CONNECT_SECONDS:g} s)")
        sock.settimeout(left)
        try:
            block = sock.recv(n - len(data))
        except socket.timeout:
            continue
        except OSError as e:
            raise _fail(scheduler, f"the connection failed ({e.strerror or e})") from None
        if not block:
            raise _fail(scheduler, "closed the connection without answering like a Dask scheduler")
        data += block
    return data


def _handshake(sock: socket.socket, scheduler: str, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    (total,) = struct.unpack("<Q", _read(sock, 8, deadline, scheduler))
    not_dask = _fail(scheduler, "answers, but not like a Dask scheduler (another service on that port?)")
    if not 16 <= total <= MAX_HANDSHAKE:
        raise not_dask
    body = _read(sock, total, deadline, scheduler)
    (frames,) = struct.unpack_from("<Q", body)
    if not 1 <= frames <= 16 or 8 + 8 * frames > total:
        raise not_dask
    lengths = struct.unpack_from(f"<{frames}Q", body, 8)
    if 8 + 8 * frames + sum(lengths) != total or b"python" not in body or b"compression" not in body:
        raise not_dask


def one_line_failure(scheduler: str, e: BaseException) -> SceneError:
    """Whatever Dask's client raised while connecting, as one line."""
    text = (str(e).strip().splitlines() or [type(e).__name__])[0]
    return _fail(scheduler, f"cannot connect ({text})")
