"""The monitor's web server (tornado): the page, its chart library, the update stream.

Routes, all ``GET`` (nothing on the page can change the session or the display):
``/`` the page; ``/static/...`` its script and style (package data); ``/uplot/...`` the chart
library (uPlot, installed from npm by ``scripts/setup`` into ``.venv/uplot``); ``/events`` the
server-sent event stream (:mod:`.stream`); ``/trace?file=traces/...`` a finished attempt's trace,
only for a file the log names.

Safe by default: bound to 127.0.0.1 on a free port, and a request whose ``Host`` is not that
address is refused (a page elsewhere cannot read the session through a DNS name pointed at this
machine). With another address (``--host``) every request must carry the random ``token`` the
printed URL holds as its first path segment (``http://ADDR:PORT/TOKEN/``): without it the
answer is 403 with an empty body, nothing else.
"""
from __future__ import annotations

import asyncio
import hmac
import json
import os
import secrets
import sys
from pathlib import Path

import tornado.iostream
import tornado.netutil
import tornado.web
from tornado.httpserver import HTTPServer
from tornado.ioloop import PeriodicCallback

from experiments.monitor.folder import FolderView
from experiments.monitor.stream import Cursor, update_for

__all__ = ["Monitor", "uplot_dir", "STATIC"]

STATIC = Path(__file__).resolve().parent / "static"
_UPLOT_FILES = ("uPlot.iife.min.js", "uPlot.min.css")
_LOCAL = ("127.0.0.1", "localhost")


def uplot_dir() -> Path | None:
    """Where uPlot's ``dist`` folder is: ``$THERMOCUE_UPLOT_DIR``, else ``.venv/uplot`` (the
    environment this Python runs in, then the checkout's)."""
    tail = Path("uplot", "node_modules", "uplot", "dist")
    candidates = [os.environ.get("THERMOCUE_UPLOT_DIR"), Path(sys.prefix) / tail,
                  Path(__file__).resolve().parents[2] / ".venv" / tail]
    for c in candidates:
        if c and all((Path(c) / f).is_file() for f in _UPLOT_FILES):
            return Path(c)
    return None


class _Guarded(tornado.web.RequestHandler):
    """Every handler. With a token, every route starts with ``/TOKEN/`` (its first argument,
    compared in constant time); without one, the ``Host`` must be the local address. Else 403
    with an empty body."""

    def prepare(self):
        m: Monitor = self.application.settings["monitor"]
        if m.token is not None:
            given = self.path_args[0] if self.path_args else ""
            ok = hmac.compare_digest(given.encode(), m.token.encode())
            self.path_args = self.path_args[1:]
        else:
            host = self.request.host.rsplit(":", 1)[0].strip("[]")
            ok = host in _LOCAL
        if not ok:
            self.forbid()
            return
        self.set_header("Cache-Control", "no-store")
        self.set_header("X-Content-Type-Options", "nosniff")
        self.set_header("Referrer-Policy", "no-referrer")

    def forbid(self):
        self.clear()
        self.clear_header("Content-Type")
        self.set_status(403)
        self.finish()

    def set_default_headers(self):
        self.clear_header("Server")

    def write_error(self, status_code, **kwargs):
        self.finish()                       # no traceback, no page: the status only


class _Forbidden(_Guarded):
    """Any other path: 403 with a token (nothing says what exists), 404 without."""

    def prepare(self):
        m: Monitor = self.application.settings["monitor"]
        if m.token is not None:
            self.forbid()
        else:
            self.clear()
            self.set_status(404)
            self.finish()


class _Page(_Guarded):
    def get(self, *_):
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.set_header("Content-Security-Policy", "default-src 'self'; style-src 'self' 'unsafe-inline'")
        self.write((STATIC / "index.html").read_bytes())


class _Files(_Guarded):
    """A fixed set of files by name (no path from the request reaches the file system)."""

    def initialize(self, files: dict):
        self.files = files

    def get(self, *args):
        name = args[-1]
        path = self.files.get(name)
        if path is None:
            raise tornado.web.HTTPError(404)
        kind = {".css": "text/css", ".svg": "image/svg+xml"}.get(path.suffix, "text/javascript")
        self.set_header("Content-Type", f"{kind}; charset=utf-8")
        self.write(path.read_bytes())


class _Trace(_Guarded):
    def get(self, *_):
        m: Monitor = self.application.settings["monitor"]
        try:
            out = m.view.trial_trace(self.get_query_argument("file", ""))
        except (OSError, ValueError) as exc:
            out = {"error": f"{self.get_query_argument('file', '')}: cannot be read ({exc})"}
        if out is None:
            raise tornado.web.HTTPError(404)
        self.set_header("Content-Type", "application/json")
        self.write(json.dumps(out))


class _Events(_Guarded):
    async def get(self, *_):
        m: Monitor = self.application.settings["monitor"]
        self.set_header("Content-Type", "text/event-stream")
        cursor, quiet = Cursor(), 0.0
        try:
            while not m.stopping:
                msg = update_for(m.view, cursor)
                if msg is not None:
                    self.write(f"data: {json.dumps(msg)}\n\n")
                    await self.flush()
                    quiet = 0.0
                elif quiet >= 15.0:
                    self.write(": still here\n\n")
                    await self.flush()
                    quiet = 0.0
                await asyncio.sleep(m.poll_s)
                quiet += m.poll_s
        except tornado.iostream.StreamClosedError:
            return


class Monitor:
    """The view of ``folder`` served on ``host``:``port`` (0: a free port)."""

    def __init__(self, folder, host: str = "127.0.0.1", port: int = 0, *, token: bool | None = None,
                 poll_s: float = 0.04, say=None, uplot: Path | None = None):
        self.view = FolderView(folder)
        self.poll_s = float(poll_s)
        local = host in _LOCAL and token is not True
        self.token = None if local else secrets.token_urlsafe(18)
        self.host = host
        self.stopping = False
        self._say = say or (lambda text: None)
        self._said = None
        uplot = uplot or uplot_dir()
        files = {name: STATIC / name for name in ("monitor.js", "monitor.css", "favicon.svg")}
        libs = {f: uplot / f for f in _UPLOT_FILES} if uplot else {}
        p = "/([^/]*)" if self.token else ""
        app = tornado.web.Application(
            [(rf"{p}/", _Page), (rf"{p}/static/([\w.-]+)", _Files, {"files": files}),
             (rf"{p}/uplot/([\w.-]+)", _Files, {"files": libs}), (rf"{p}/events", _Events),
             (rf"{p}/trace", _Trace), (r".*", _Forbidden)],
            monitor=self, compress_response=False, log_function=lambda handler: None)
        self.sockets = tornado.netutil.bind_sockets(port, address=host)
        self.port = self.sockets[0].getsockname()[1]
        self.server = HTTPServer(app)
        self._app = app

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/" + (f"{self.token}/" if self.token else "")

    def poll(self) -> None:
        try:
            self.view.poll()
        except Exception as exc:          # never a traceback: the page and the terminal say it
            self.view.problem = (f"{self.view.folder}: cannot be followed "
                                 f"({type(exc).__name__}: {exc})")
        if self.view.problem != self._said:
            if self.view.problem is not None:
                self._say(self.view.problem)
            elif self._said is not None:
                self._say(f"{self.view.folder}: read again")
            self._said = self.view.problem

    def start(self) -> None:
        """Serve on the running event loop (call inside it)."""
        self.poll()
        self.server.add_sockets(self.sockets)
        self._poller = PeriodicCallback(self.poll, self.poll_s * 1000)
        self._poller.start()

    def stop(self) -> None:
        self.stopping = True
        self._poller.stop()
        self.server.stop()
