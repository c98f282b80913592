"""Run the page app with uvicorn in a background thread (tests, benchmarks, notebooks, the
lab page, ``surfhap serve --no-web-process``)."""

from __future__ import annotations

import socket
import threading
import time

from surfhap.live.config import ServerConfig

__all__ = ["ServerThread"]


class ServerThread:
    """Run uvicorn for ``app`` in a background thread."""

    def __init__(self, app, host: str = "127.0.0.1", port: int = 0, max_message_bytes: int = 1024,
                 config: ServerConfig | None = None):
        """``config``: the limits to serve with (connection cap, timeouts, message size);
        by default a :class:`ServerConfig` with ``max_message_bytes``. ``host``/``port``
        are where to bind (port 0: any free port, see :attr:`port`)."""
        import uvicorn

        from surfhap.live.httpguard import uvicorn_config

        self._sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._sock.bind((host, port))
        self.host, self.port = host, self._sock.getsockname()[1]
        self.app = app
        cfg = config or ServerConfig(host=host, port=port, max_message_bytes=max_message_bytes)
        uconfig, self.guard = uvicorn_config(app, cfg)
        self.server = uvicorn.Server(uconfig)
        self._thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self._sock]},
                                        name="surfhap-http", daemon=True)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def start(self, timeout: float = 10.0) -> "ServerThread":
        """Start serving; raises RuntimeError when uvicorn is not up within ``timeout`` s."""
        self._thread.start()
        end = time.monotonic() + timeout
        while not self.server.started and time.monotonic() < end:
            time.sleep(0.02)
        if not self.server.started:
            raise RuntimeError("the web server did not start")
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        self._thread.join(5.0)
        self._sock.close()
