"""``HOST:PORT`` and ``osc://HOST:PORT[/PATH]`` options, checked without any network call.

The one parser of every address option (``--output osc://``, ``--device``, ``--feedback``,
``--touch osc://``, ``--osc-in``, ``--device-listen``). A host is an IP address (IPv6 in
brackets, or bare) or a syntactically valid host name (RFC 1123 labels); a dotted all-numeric
name must be a valid IPv4 address, so ``999.1.1.1`` is refused here instead of being sent to
DNS. A port is 1-65535 (0, "any free port", only where the option listens). Errors are a
:class:`~surfhap.errors.ConfigError` naming the option.
"""

from __future__ import annotations

import ipaddress
import re

from surfhap.errors import ConfigError

__all__ = ["check_host", "parse_host_port", "parse_osc_address", "parse_url", "parse_netft_address"]

_LABEL = re.compile(r"^(?!-)[A-Za-z0-9-]{1,63}(?<!-)$")


def check_host(host: str, option: str) -> str:
    """``host`` (brackets of an IPv6 literal removed) if it is an IP address or a valid host
    name; ConfigError naming ``option`` otherwise. Never resolves the name."""
    h = host.strip()
    bracketed = h.startswith("[") and h.endswith("]")
    if bracketed:
        h = h[1:-1]
    try:
        ip = ipaddress.ip_address(h)
    except ValueError:
        ip = None
    if ip is not None:
        if bracketed and ip.version != 6:
            raise ConfigError(f"{host!r}: brackets hold an IPv6 address", source=option, field="host")
        return h
    if not h:
        raise ConfigError("the host is missing", source=option, field="host")
    labels = h[:-1].split(".") if h.endswith(".") else h.split(".")
    if all(label.isdigit() for label in labels):
        raise ConfigError(f"{host!r} is not a valid IPv4 address (each of the 4 numbers is 0-255)", source=option,
                          field="host")
    if bracketed or len(h) > 253 or not all(_LABEL.match(label) for label in labels) or labels[-1].isdigit():
        raise ConfigError(f"{host!r} is neither an IP address nor a valid host name", source=option, field="host")
    return h


def _port(text: str, option: str, listen: bool) -> int:
    lo = 0 if listen else 1
    if not text.isdigit() or not lo <= int(text) <= 65535:
        shown = repr(text) if text else "missing"
        raise ConfigError(f"{shown} is not a number in {lo}-65535", source=option, field="port")
    return int(text)


def parse_host_port(text: str, option: str, *, listen: bool = False) -> tuple[str, int]:
    """``HOST:PORT`` (``[IPv6]:PORT``) -> (host, port); ``listen`` also allows port 0."""
    s = (text or "").strip()
    if s.startswith("["):
        inner, sep, rest = s[1:].partition("]")
        if not sep or not rest.startswith(":"):
            raise ConfigError(f"expected HOST:PORT, got {text!r}", source=option)
        host, port = f"[{inner}]", rest[1:]
    else:
        host, sep, port = s.rpartition(":")
        if not sep:
            raise ConfigError(f"expected HOST:PORT, got {text!r}", source=option)
    return check_host(host, option), _port(port, option, listen)


def _after_scheme(text: str, scheme: str, option: str, form: str) -> str:
    s = (text or "").strip()
    if not s.startswith(f"{scheme}://"):
        raise ConfigError(f"expected {scheme}://{form}, got {text!r}", source=option)
    return s[len(scheme) + 3:]


def parse_osc_address(text: str, option: str, *, listen: bool = False, scheme: str = "osc") -> tuple[str, int, str]:
    """``osc://HOST:PORT[/PATH]`` (or another ``scheme``) -> (host, port, path without slashes,
    "" when absent)."""
    rest = _after_scheme(text, scheme, option, "HOST:PORT")
    if rest.startswith("["):
        close = rest.find("]")
        cut = rest.find("/", close if close >= 0 else 0)
    else:
        cut = rest.find("/")
    netloc, path = (rest, "") if cut < 0 else (rest[:cut], rest[cut:])
    host, port = parse_host_port(netloc, option, listen=listen)
    return host, port, path.strip("/")


def parse_url(text: str, option: str, scheme: str = "osc", *, listen: bool = False) -> tuple[str, int]:
    """``SCHEME://HOST:PORT`` without a path (``osc://`` devices and feedback, ``haply://``) ->
    (host, port); port 0 only where the option listens."""
    host, port, path = parse_osc_address(text, option, listen=listen, scheme=scheme)
    if path:
        raise ConfigError(f"expected {scheme}://HOST:PORT, got {text!r}", source=option)
    return host, port


def parse_netft_address(text: str, option: str) -> tuple[str, int, int]:
    """``netft://HOST[:PORT][?http=PORT]`` -> (host, RDT UDP port, HTTP port); the defaults 49152
    and 80 are the Net F/T's (ATI manual 9620-05-NET FT, RDT section and web server)."""
    netloc, _, query = _after_scheme(text, "netft", option, "HOST[:PORT]").rstrip("/").partition("?")
    http = 80
    if query:
        key, _, value = query.partition("=")
        if key != "http":
            raise ConfigError(f"unknown parameter {key!r} (only ?http=PORT)", source=option)
        http = _port(value, option, False)
    if netloc.endswith("]") or ":" not in netloc or (netloc.count(":") > 1 and not netloc.startswith("[")):
        return check_host(netloc, option), 49152, http
    return (*parse_host_port(netloc, option), http)
