"""Pieces shared by the command groups: listen addresses."""

from __future__ import annotations

import ipaddress

import click


def parse_listen(value: str) -> tuple[str, int]:
    """``HOST:PORT`` or ``[IPv6]:PORT`` -> (host, port); raises ValueError."""
    host, sep, port_text = value.rpartition(":")
    if not sep or not host:
        raise ValueError(f"expected HOST:PORT, got {value!r}")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    if not port_text.isdigit() or not 0 <= int(port_text) <= 65535:
        raise ValueError(f"port must be a number 0..65535, got {port_text!r}")
    return host, int(port_text)


def format_address(host: str, port: int) -> str:
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def is_loopback(host: str) -> bool:
    """True for addresses only this machine reaches (127.0.0.0/8, ::1, localhost)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


_ALLOW_REMOTE = "sondalog.allow_remote"


def listen_option(ctx: click.Context, param: click.Parameter, value: str) -> tuple[str, int]:
    try:
        host, port = parse_listen(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc), ctx, param) from exc
    if not is_loopback(host) and not ctx.meta.get(_ALLOW_REMOTE, False):
        raise click.BadParameter(
            f"{host} is reachable from other machines, and the ALA1 and HCTMPS1 protocols have "
            "no authentication (docs/security.md); add --allow-remote to listen there anyway",
            ctx,
            param,
        )
    return host, port


def _remember_allow_remote(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[_ALLOW_REMOTE] = value


#: ``--allow-remote``: the explicit consent to listen beyond loopback (issue 9).
allow_remote_option = click.option(
    "--allow-remote",
    is_flag=True,
    is_eager=True,
    expose_value=False,
    callback=_remember_allow_remote,
    help="Allow a --listen address beyond loopback (no authentication: see docs/security.md).",
)
