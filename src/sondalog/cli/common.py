"""Pieces shared by the command groups: listen addresses."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

from sondalog.config.address import format_address, is_loopback, parse_listen

F = TypeVar("F", bound=Callable[..., Any])

__all__ = [
    "Refused",
    "allow_remote_option",
    "allow_remote_site_option",
    "format_address",
    "is_loopback",
    "listen_option",
    "parse_listen",
    "refuses_remote",
    "speed_option",
]


_ALLOW_REMOTE = "sondalog.allow_remote"


def listen_option(ctx: click.Context, param: click.Parameter, value: str) -> tuple[str, int]:
    try:
        host, port = parse_listen(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc), ctx, param) from exc
    if refuses_remote(ctx, host):
        raise click.BadParameter(
            f"{host} is reachable from other machines, and the ALA1 and HCTMPS1 protocols have "
            "no authentication (docs/security.md); add --allow-remote to listen there anyway",
            ctx,
            param,
        )
    return host, port


def refuses_remote(ctx: click.Context, host: str) -> bool:
    """True if ``host`` is beyond loopback and the command was not given ``--allow-remote``."""
    return not is_loopback(host) and not ctx.meta.get(_ALLOW_REMOTE, False)


def _remember_allow_remote(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[_ALLOW_REMOTE] = value


def _allow_remote(help_text: str) -> Callable[[F], F]:
    return click.option(
        "--allow-remote",
        is_flag=True,
        is_eager=True,
        expose_value=False,
        callback=_remember_allow_remote,
        help=help_text,
    )


#: ``--allow-remote``: the explicit consent to listen beyond loopback (issue 9).
allow_remote_option = _allow_remote(
    "Allow a --listen address beyond loopback (no authentication: see docs/security.md)."
)
#: The same for ``serve``, whose addresses are the ``listen`` fields of its site file.
allow_remote_site_option = _allow_remote(
    "Allow listen addresses of the site file beyond loopback (no authentication: see "
    "docs/security.md)."
)


class Refused(click.ClickException):
    """A usage problem found after parsing (exit code 2, like click's own usage errors)."""

    exit_code = 2


def speed_option(what: str) -> Callable[[F], F]:
    """``--speed F``: ``what`` runs F times faster than real time; the lines keep real time
    (docs/decisions.md "Time base")."""
    return click.option(
        "--speed",
        type=click.FloatRange(min=0, min_open=True),
        default=1.0,
        show_default=True,
        help=f"Run {what} this many times faster than real time.",
    )
