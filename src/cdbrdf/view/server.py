"""The local web server of ``cdbrdf view``: the viewer's files from memory, on 127.0.0.1 only.

:class:`ViewerServer` serves the files of :func:`cdbrdf.view.export.viewer_files`
(GET and HEAD; anything else is 404 or 405), never the file system. A free
port is chosen unless one is given; a port in use is an
:class:`~cdbrdf.errors.OptionError` naming it.

Only the viewer's own page gets the user's table:

- a request whose ``Host`` is not the address served (``127.0.0.1:PORT``
  or ``localhost:PORT``) is refused (403): a page of another site whose
  name resolves to 127.0.0.1 (DNS rebinding) reaches nothing;
- every file but the page itself (``data.js`` holds the table) is refused
  to a request from another origin, as its ``Origin``, ``Referer`` or
  ``Sec-Fetch-Site`` header says (a ``<script src>`` on another site's page),
  and every answer carries ``Cross-Origin-Resource-Policy: same-origin``,
  which makes browsers refuse to hand it to another origin;
- a request with two ``Host`` (or ``Origin``, ``Referer``, ``Sec-Fetch-*``)
  headers is refused (400), as HTTP requires; a malformed ``Origin`` is
  another origin (403);
- a connection silent for :data:`IDLE_TIMEOUT_S` seconds is closed, and at
  most :data:`MAX_CONNECTIONS` are answered at once (more are closed at
  once), so half-open connections cannot hold the server's threads;
- a client that goes away mid-answer (a reset, a closed tab) is logged on
  one line (debug level), never with a traceback.
"""

from __future__ import annotations

import errno
import logging
import sys
import threading
from collections.abc import Mapping
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from types import TracebackType
from typing import Any
from urllib.parse import unquote, urlsplit

from ..errors import OptionError

__all__ = ["HOST", "CONTENT_TYPES", "IDLE_TIMEOUT_S", "MAX_CONNECTIONS", "ViewerServer"]

_LOG = logging.getLogger(__name__)

#: The only address served: this machine.
HOST = "127.0.0.1"

#: Content types by suffix.
CONTENT_TYPES: Mapping[str, str] = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".json": "application/json",
    ".bin": "application/octet-stream",
}


#: The page itself: the only file served to a navigation from another site (it holds no data).
_PAGE = "index.html"

#: Headers of every answer: no other origin gets it, no type sniffing, no framing, no caching.
_HEADERS = {"Cross-Origin-Resource-Policy": "same-origin", "X-Content-Type-Options": "nosniff",
            "X-Frame-Options": "DENY", "Cache-Control": "no-store"}


#: Seconds a connection may stay silent before it is closed (a half-open connection holds a thread).
IDLE_TIMEOUT_S = 10.0

#: Connections answered at once; more are closed at once (a page opens a handful).
MAX_CONNECTIONS = 32

#: Request headers that must appear at most once (HTTP/1.1, RFC 9110 5.3 and 7.2: two Hosts are a 400).
_SINGLE = ("Host", "Origin", "Referer", "Sec-Fetch-Site", "Sec-Fetch-Mode")


def _origin(url: str) -> str:
    """``scheme://host:port`` of a URL, lower case ("" when it has none, "?" when it is malformed)."""
    try:
        parts = urlsplit(url.strip())
    except ValueError:  # "http://[::1": an unclosed IPv6 literal
        return "?"
    return f"{parts.scheme}://{parts.netloc}".lower() if parts.scheme and parts.netloc else ""


def _handler(files: Mapping[str, bytes]) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        server_version = "cdbrdf-view"
        timeout = IDLE_TIMEOUT_S  # socket timeout: a silent connection is closed (http.server logs it)

        def _lookup(self) -> tuple[str, bytes, str] | None:
            path = unquote(urlsplit(self.path).path).lstrip("/") or _PAGE
            data = files.get(path)
            if data is None:
                return None
            suffix = path[path.rfind("."):] if "." in path else ""
            return path, data, CONTENT_TYPES.get(suffix, "application/octet-stream")

        def _refusal(self, path: str) -> str | None:
            """Why this request must not be answered (None: it may)."""
            port = int(self.server.server_address[1])  # type: ignore[index]
            hosts = {f"{HOST}:{port}", f"localhost:{port}"}
            if (self.headers.get("Host") or "").strip().lower() not in hosts:
                return f"this server answers requests for {HOST}:{port} only"
            ours = {f"http://{h}" for h in hosts}
            if path == _PAGE and self.headers.get("Sec-Fetch-Mode", "navigate") == "navigate":
                return None  # opening the page itself: it holds nothing of the table
            origin = self.headers.get("Origin")
            if origin is not None and _origin(origin) not in ours:
                return "not served to other origins"
            referer = self.headers.get("Referer")
            if referer is not None and _origin(referer) not in ours:
                return "not served to other origins"
            if self.headers.get("Sec-Fetch-Site", "same-origin") not in ("same-origin", "none"):
                return "not served to other origins"
            return None

        def _send(self, body: bool) -> None:
            found = self._lookup()
            if found is None:
                self.send_error(404, "not part of the viewer")
                return
            path, data, ctype = found
            twice = [h for h in _SINGLE if len(self.headers.get_all(h) or ()) > 1]
            if twice:
                self.send_error(400, f"more than one {twice[0]} header")
                return
            why = self._refusal(path)
            if why is not None:
                _LOG.info("refused %s %s from %s: %s", self.command, path, self.address_string(), why)
                self.send_error(403, why)
                return
            self.send_response(200)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(data)))
            for k, v in _HEADERS.items():
                self.send_header(k, v)
            self.end_headers()
            if body:
                self.wfile.write(data)

        def do_GET(self) -> None:  # noqa: N802 - the http.server API
            self._send(True)

        def do_HEAD(self) -> None:  # noqa: N802
            self._send(False)

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the http.server API
            _LOG.debug("%s " + format, self.address_string(), *args)

    return Handler


class _Server(ThreadingHTTPServer):
    """The HTTP server: at most :data:`MAX_CONNECTIONS` at once; errors while answering are one log line."""

    daemon_threads = True
    request_queue_size = 2 * MAX_CONNECTIONS  # the listen backlog (5 by default: a burst waited for SYN retries)

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._slots = threading.BoundedSemaphore(MAX_CONNECTIONS)

    def process_request(self, request: Any, client_address: Any) -> None:  # noqa: D102 - socketserver API
        if not self._slots.acquire(blocking=False):
            _LOG.info("refused a connection from %s: %d connections are open", client_address[0], MAX_CONNECTIONS)
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)
        except BaseException:
            self._slots.release()
            raise

    def process_request_thread(self, request: Any, client_address: Any) -> None:  # noqa: D102 - socketserver API
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._slots.release()

    def handle_error(self, request: Any, client_address: Any) -> None:  # noqa: D102 - socketserver API
        exc = sys.exc_info()[1]
        if isinstance(exc, (ConnectionError, TimeoutError)):  # reset, broken pipe, aborted: the client left
            _LOG.debug("client %s went away: %s", client_address[0], exc)
        else:
            _LOG.warning("answering %s failed: %s: %s", client_address[0], type(exc).__name__, exc)


class ViewerServer:
    """A web server of the viewer's files on :data:`HOST`.

    Parameters
    ----------
    files
        Relative path -> bytes (:func:`cdbrdf.view.export.viewer_files`).
    port
        TCP port; 0 (default) picks a free one.

    Raises
    ------
    OptionError
        When the port is in use or cannot be bound (the message names it).
    """

    def __init__(self, files: Mapping[str, bytes], *, port: int = 0) -> None:
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise OptionError(f"port: expected an integer in [0, 65535], got {port!r}")
        try:
            self._httpd = _Server((HOST, port), _handler(dict(files)))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise OptionError(f"port {port}: already in use on {HOST}; choose another --port "
                                  "or leave it out for a free one") from None
            raise OptionError(f"port {port}: cannot serve on {HOST} ({exc.strerror or exc})") from None
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        """The port served."""
        return int(self._httpd.server_address[1])

    @property
    def url(self) -> str:
        """The viewer's address."""
        return f"http://{HOST}:{self.port}/"

    def serve_forever(self) -> None:
        """Serve until :meth:`shutdown` (from another thread) or an interrupt."""
        self._httpd.serve_forever(poll_interval=0.2)

    def start(self) -> ViewerServer:
        """Serve from a background thread (tests, scripts).

        Returns
        -------
        ViewerServer
            This server.
        """
        self._thread = threading.Thread(target=self.serve_forever, name="cdbrdf-view", daemon=True)
        self._thread.start()
        return self

    def shutdown(self) -> None:
        """Stop serving and close the socket."""
        if self._thread is not None:
            self._httpd.shutdown()
            self._thread.join()
            self._thread = None
        self._httpd.server_close()

    def close(self) -> None:
        """Close the socket (after :meth:`serve_forever` returned)."""
        self._httpd.server_close()

    def __enter__(self) -> ViewerServer:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.shutdown()
