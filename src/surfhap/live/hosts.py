"""Who may reach the page: the ``Host`` allow list and the ``Origin`` rule, both applied by
the request guard of every web app (:mod:`surfhap.live.webguard`).

The ``Host`` header must name a loopback name, the bound address or one of the
``--allow-host`` names (``*.example.org`` patterns allowed); a wildcard bind (0.0.0.0,
::) widens nothing, which keeps DNS rebinding out. A WebSocket's ``Origin`` must be the
page's own (``http://`` + ``Host``) or an ``--allow-origin``; a client without ``Origin``
(not a browser) is allowed only with ``allow_missing_origin``. The same ``Origin`` rule
guards every state-changing HTTP request (CSRF).
"""

from __future__ import annotations

__all__ = ["host_allow_list", "OriginRule", "LOOPBACK_NAMES", "WILDCARD_HOSTS"]

WILDCARD_HOSTS = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")  # as a Host header names them (IPv6 in brackets)


def _as_host(name: str) -> str:
    name = name.strip().lower().rstrip(".")
    return f"[{name}]" if ":" in name and not name.startswith("[") else name


def host_allow_list(bind_host: str, allowed_hosts=()) -> tuple[str, ...]:
    """The names a ``Host`` header may carry (lower case, IPv6 literals in brackets): the
    loopback names, the bound address (unless it is a wildcard) and ``allowed_hosts``
    (exact names or ``*.domain`` patterns)."""
    names = [*LOOPBACK_NAMES, *(_as_host(h) for h in allowed_hosts)]
    if bind_host not in WILDCARD_HOSTS:
        names.append(_as_host(bind_host))
    return tuple(dict.fromkeys(n for n in names if n))


class OriginRule:
    """The ``Origin`` check of WebSockets and state-changing requests (see module doc)."""

    def __init__(self, allowed_origins=(), allow_missing: bool = True):
        self.allowed = {o.rstrip("/").lower() for o in allowed_origins}
        self.allow_missing = bool(allow_missing)

    def __call__(self, origin: str | None, host_header: str | None) -> bool:
        if origin is None:
            return self.allow_missing
        o = origin.rstrip("/").lower()
        if o in self.allowed:
            return True
        return bool(host_header) and o == "http://" + host_header.strip().lower()
