"""Network addresses as a server of ours tells them: the Foxglove server and the
TUI's web server say where they listen and who can reach them."""

from __future__ import annotations

import ipaddress

WILDCARDS = ("0.0.0.0", "::", "")   # bound to every interface
LOCAL_HOST = "127.0.0.1"   # where a server of ours listens unless told: this machine only


def show_address(host: str, port: int) -> str:
    """``host:port``, an IPv6 host in brackets."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def is_loopback(host: str) -> bool:
    """Only this machine reaches ``host`` (127.0.0.0/8, ::1, localhost)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:   # a name: it may resolve to any interface
        return False


def who_reaches(host: str) -> str:
    """Who can reach a server bound to ``host``, in words."""
    if is_loopback(host):
        return "only this machine"
    if host in WILDCARDS:
        return "anyone who can reach this machine on any of its networks, with no password"
    return f"anyone who can reach {host} on its network, with no password"
