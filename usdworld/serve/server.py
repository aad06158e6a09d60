"""Run the app with uvicorn on a socket bound up front, until Ctrl-C (or SIGTERM).

The socket is bound and listening before :func:`serve_forever` starts uvicorn, so
``--port 0`` can report the port the system chose, and a browser opened on the printed URL
at once waits in the backlog instead of being refused. On Ctrl-C uvicorn stops accepting,
lets running requests finish (each edit is one locked transaction with an atomic save, so
an interrupted server never leaves a half-written layer), runs the app's shutdown (which
closes the editor) and returns.
"""

from __future__ import annotations

import ipaddress
import logging
import signal
import socket
from dataclasses import dataclass
from types import FrameType

from usdworld.errors import OutputError

log = logging.getLogger(__name__)

#: Seconds uvicorn waits for running requests when stopping.
GRACEFUL_SHUTDOWN_S = 5


@dataclass(frozen=True)
class Listener:
    """A bound, listening socket and how to reach it.

    Attributes:
        sock: the socket.
        host: the address it is bound to.
        port: the port (the system's choice for ``--port 0``).
        loopback: True when only this machine can reach it.
        url_host: the host to put in the URL (``127.0.0.1`` for a wildcard address).
    """

    sock: socket.socket
    host: str
    port: int
    loopback: bool
    url_host: str

    def url(self, token: str) -> str:
        """The page's URL with the session token."""
        return f"http://{self.url_host}:{self.port}/?token={token}"


def bind(host: str, port: int) -> Listener:
    """Bind and listen on ``host:port``.

    Raises:
        OutputError: the address cannot be resolved or the port is taken.
    """
    if not 0 <= port <= 65535:
        raise OutputError(f"--port {port}: must be 0 (any free port) to 65535")
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    except socket.gaierror as exc:
        raise OutputError(f"--host {host}: cannot resolve it ({exc.strerror})") from exc
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(128)
    except OSError as exc:
        sock.close()
        raise OutputError(
            f"--host {host} --port {port}: cannot listen there ({exc.strerror}); "
            "pick another port, or --port 0 for any free one"
        ) from exc
    bound_host, bound_port = sock.getsockname()[:2]
    ip = ipaddress.ip_address(bound_host)
    if ip.is_unspecified:
        url_host = "127.0.0.1" if ip.version == 4 else "[::1]"
    else:
        url_host = f"[{bound_host}]" if ip.version == 6 else bound_host
    return Listener(sock, bound_host, int(bound_port), ip.is_loopback, url_host)


class _Stop(Exception):
    pass


def _raise_stop(signum: int, frame: FrameType | None) -> None:
    raise _Stop()


def serve_forever(app: object, listener: Listener, *, access_log: bool = False) -> None:
    """Serve ``app`` on ``listener`` until Ctrl-C or SIGTERM; returns after a clean shutdown."""
    import uvicorn

    config = uvicorn.Config(
        app,  # type: ignore[arg-type]
        log_level="info" if access_log else "warning",
        access_log=access_log,
        lifespan="on",
        timeout_graceful_shutdown=GRACEFUL_SHUTDOWN_S,
        server_header=False,
    )
    server = uvicorn.Server(config)
    # uvicorn handles the signals itself and re-raises them once it has shut down; these
    # handlers turn that re-raise into a normal return.
    previous = {sig: signal.signal(sig, _raise_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        server.run(sockets=[listener.sock])
    except (_Stop, KeyboardInterrupt):
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        listener.sock.close()
