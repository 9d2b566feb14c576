"""The address of the client that sent a request, for per-address limits.

The connection's peer is the client unless it is one of the configured trusted reverse
proxies (``ALCOVE_TRUSTED_PROXIES``). Only then is ``X-Forwarded-For`` read: from the right,
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


def client_address(request: Request, proxies: Sequence[IPNetwork]) -> str:
    """The client's address as a string (normalised when it is an IP address)."""
    peer_text = request.client.host if request.client else ""
    peer = parse_ip(peer_text)
    if not _trusted(peer, proxies):
        return str(peer) if peer is not None else (peer_text or "unknown")
    hops = [h for value in request.headers.getlist("x-forwarded-for") for h in value.split(",") if h.strip()]
    client: IPAddress = peer  # type: ignore[assignment]
    for hop in reversed(hops):
        ip = parse_ip(hop)
        if ip is None:  # garbage: keep the last address a trusted proxy vouched for
            break
        client = ip
        if not _trusted(ip, proxies):
            break
    return str(client)
