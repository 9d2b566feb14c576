"""The address of the client that sent a request, for per-address limits.

The connection's peer is the client unless it is one of the configured trusted reverse
proxies (``ALCOVE_TRUSTED_PROXIES``). Only then is the forwarding header the proxies write
(``ALCOVE_FORWARDED_HEADER``: ``X-Forwarded-For``, or the standard ``Forwarded`` of RFC 7239,
of which the ``for=`` parameters count) read: from the right,
every address that is itself a trusted proxy is skipped, and the first one that is not is
the client (what the outermost trusted proxy saw). Anyone can send the header, so it is
never believed from an untrusted peer, and the entries left of the first untrusted one
(written by the client itself) are never used.

uvicorn rewrites the peer from ``X-Forwarded-For`` itself when its ``proxy_headers`` option
is on (it is by default, trusting 127.0.0.1): ``alcove serve`` turns that off, so the peer
seen here is the real one.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Sequence

from starlette.requests import Request

from alcove.settings import IPNetwork

IPAddress = ipaddress.IPv4Address | ipaddress.IPv6Address


def parse_ip(text: str) -> IPAddress | None:
    """An address from a peer or header entry (IPv6 possibly in brackets), or None."""
    text = text.strip()
    if text.startswith("[") and text.endswith("]"):
        text = text[1:-1]
    try:
        ip = ipaddress.ip_address(text)
    except ValueError:
        return None
    mapped = getattr(ip, "ipv4_mapped", None)  # ::ffff:1.2.3.4 is 1.2.3.4
    return mapped or ip


def _trusted(ip: IPAddress | None, proxies: Sequence[IPNetwork]) -> bool:
    return ip is not None and any(ip.version == net.version and ip in net for net in proxies)


def in_networks(address: str, networks: Sequence[IPNetwork]) -> bool:
    """``address`` (a client address as :func:`client_address` gives it) lies in one of ``networks``."""
    return _trusted(parse_ip(address), networks)


def _forwarded_for(element: str) -> str:
    """The ``for=`` node of one element of a ``Forwarded`` header (RFC 7239), without quotes
    and port: ``for="[2001:db8::1]:4711"`` is ``[2001:db8::1]``; "" when there is none."""
    for pair in element.split(";"):
        name, _, value = pair.strip().partition("=")
        if name.strip().lower() == "for":
            node = value.strip().strip('"')
            if node.startswith("["):
                return node[: node.find("]") + 1] if "]" in node else node
            return node.rsplit(":", 1)[0] if node.count(":") == 1 else node
    return ""


def forwarded_hops(request: Request, header: str = "x-forwarded-for") -> list[str]:
    """The addresses the forwarding header lists, client first (several header lines are one list)."""
    values = [item for value in request.headers.getlist(header) for item in value.split(",") if item.strip()]
    return [_forwarded_for(v) for v in values] if header == "forwarded" else values


def client_address(request: Request, proxies: Sequence[IPNetwork], header: str = "x-forwarded-for") -> str:
    """The client's address as a string (normalised when it is an IP address)."""
    peer_text = request.client.host if request.client else ""
    peer = parse_ip(peer_text)
    if peer is None or not _trusted(peer, proxies):
        return str(peer) if peer is not None else (peer_text or "unknown")
    hops = forwarded_hops(request, header)
    client: IPAddress = peer
    for hop in reversed(hops):
        ip = parse_ip(hop)
        if ip is None:  # garbage: keep the last address a trusted proxy vouched for
            break
        client = ip
        if not _trusted(ip, proxies):
            break
    return str(client)
