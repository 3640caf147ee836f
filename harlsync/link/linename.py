"""Which line a port URL names: one key per line, whatever the port is called.

``/dev/serial/by-id/...`` and ``/dev/ttyUSB0`` are one line, ``localhost`` and
``127.0.0.1`` one machine, a family's own TCP scheme (``scheme://HOST``) the
``socket://`` line of its host and port.  The line lock names its file after
this key (:func:`harlsync.link.lock.lock_path`), which re-exports these names.
"""

from __future__ import annotations

import ipaddress
import os
import re
import socket
from urllib.parse import urlsplit

from .. import lookup

__all__ = ["add_tcp_scheme", "is_com_port", "lock_key", "port_number"]

_COM_RE = re.compile(r"(?:\\\\\.\\)?(COM\d+)", re.IGNORECASE)
#: URL schemes of one TCP endpoint each, as pyserial has them: the port is in the URL.
_SERIAL_TCP_SCHEMES = ("socket", "rfc2217")
#: The families' own TCP schemes -> the port of a URL that names none: such a URL is
#: the ``socket://`` line of its host and port (one controller, whatever speaks to it).
_TCP_SCHEMES: dict[str, int] = {}


def add_tcp_scheme(name: str, default_port: int) -> None:
    """Take ``name://HOST[:PORT]`` URLs as the TCP endpoint they name, with
    ``default_port`` when they name none."""
    _TCP_SCHEMES[name.lower()] = default_port


def _tcp_scheme(scheme: str) -> int | None:
    """The default port of a family's TCP scheme, or None if it is none."""
    if scheme not in _TCP_SCHEMES:
        for name, port in lookup.tcp_schemes().items():
            add_tcp_scheme(name, port)
    return _TCP_SCHEMES.get(scheme)


def is_com_port(url: str) -> bool:
    """Whether ``url`` names a Windows COM port (``COM3``, ``\\\\.\\COM12``)."""
    return _COM_RE.fullmatch(url) is not None


def lock_key(url: str) -> str | None:
    """The identity of the line ``url`` opens, or None for one no other process can share.

    Device paths resolve symlinks (``/dev/serial/by-id/...`` and ``/dev/ttyUSB0``
    are one line), ``COM3`` is upper-cased, ``spy://`` is the port it wraps,
    ``socket://`` and ``rfc2217://`` are host:port without options, the host
    resolved (``localhost`` and ``127.0.0.1`` are one machine), a family's own
    TCP scheme (:func:`add_tcp_scheme`) is the ``socket://`` line of its host:port
    (the family's default port when it has none: one harlsync per controller,
    whatever speaks to it), ``loop://`` is private to its process (None), any
    other URL is taken as it is.
    """
    if "://" not in url:
        com = _COM_RE.fullmatch(url)
        if com:
            return com.group(1).upper()
        return os.path.realpath(url)
    scheme = url.split("://", 1)[0].lower()
    parts = urlsplit(url)
    if scheme == "loop":
        return None
    if scheme == "spy":
        return lock_key(parts.netloc + parts.path)
    default_port = None if scheme in _SERIAL_TCP_SCHEMES else _tcp_scheme(scheme)
    if scheme in _SERIAL_TCP_SCHEMES or default_port is not None:
        port = port_number(url)
        if default_port is not None:
            scheme = "socket"  # one TCP endpoint, one controller
            if port is None and ":" not in parts.netloc.rpartition("]")[2]:
                port = default_port
        if port is None:  # not a port number: opening it will say so
            return f"{scheme}://{parts.netloc.lower()}"
        return f"{scheme}://{_host_key(parts.hostname or '')}:{port}"
    return url


def port_number(url: str) -> int | None:
    """The TCP port of a ``socket://`` or ``rfc2217://`` URL (or of a family's TCP
    scheme), or None if it has none."""
    try:
        return urlsplit(url).port
    except ValueError:
        return None


def _host_key(host: str) -> str:
    """One name per machine: ``localhost``, ``127.0.0.1`` and ``::1`` are one
    (``loopback``), a name and its address are one (the lowest address it has)."""
    try:
        addresses = sorted({str(info[4][0]) for info in socket.getaddrinfo(host, None)})
    except (OSError, UnicodeError):
        return host.lower()  # unknown: opening the port will say so
    if not addresses:
        return host.lower()
    try:
        if any(ipaddress.ip_address(a.split("%", 1)[0]).is_loopback for a in addresses):
            return "loopback"
    except ValueError:
        pass
    return addresses[0]
