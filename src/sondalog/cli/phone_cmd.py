"""``sondalog phone ...``: a phone of the simulated GSM network (parsing only; the work is in
:mod:`sondalog.client.phone`, over the network's HTTP API; docs/gsm.md)."""

from __future__ import annotations

import json
from typing import Any

import click

from sondalog.client.phone import DEFAULT_API, PhoneApi, PhoneApiError


def _api(ctx: click.Context) -> PhoneApi:
    return PhoneApi(str(ctx.obj))


def _run(what: Any, *args: Any) -> Any:
    try:
        return what(*args)
    except PhoneApiError as exc:
        if exc.status == 0:
            raise click.ClickException(exc.message) from None
        raise click.UsageError(exc.message) from None  # exit code 2: the request was wrong


@click.group()
@click.option(
    "--api",
    default=DEFAULT_API,
    show_default=True,
    help="The network's HTTP API (the [gsm.serve] api of the served site).",
)
@click.pass_context
def phone(ctx: click.Context, api: str) -> None:
    """Send and read SMS and place calls as a phone of a served GSM network."""
    ctx.obj = api


@phone.command()
@click.argument("sender", metavar="FROM")
@click.argument("to")
@click.argument("text")
@click.pass_context
def sms(ctx: click.Context, sender: str, to: str, text: str) -> None:
    """Send TEXT from phone FROM to number TO (queued while TO is unreachable)."""
    result = _run(_api(ctx).sms, sender, to, text)
    state = "queued (the recipient is not reachable now)" if result["queued"] else "delivered"
    click.echo(f"SMS {', '.join(str(i) for i in result['ids'])} {state}")


@phone.command()
@click.argument("number")
@click.option("--queued", is_flag=True, help="Show the SMS still waiting at the SMS centre.")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON list.")
@click.pass_context
def inbox(ctx: click.Context, number: str, queued: bool, as_json: bool) -> None:
    """List the SMS delivered to NUMBER, oldest first ("no SMS ..." when there is none)."""
    messages = _run(_api(ctx).inbox, number, queued)
    if as_json:
        click.echo(json.dumps(messages, ensure_ascii=False, indent=2))
        return
    if not messages:
        where = "waiting at the SMS centre for" if queued else "delivered to"
        click.echo(f"no SMS {where} {number}")
    for sms in messages:
        click.echo(f"{sms['time']}  from {sms['from']}")
        for line in sms["text"].splitlines() or [""]:
            click.echo(f"  {line}")


@phone.command()
@click.argument("sender", metavar="FROM")
@click.argument("to")
@click.option("--voice", "kind", flag_value="voice", default=True, help="A voice call (default).")
@click.option("--data", "kind", flag_value="data", help="A data call (CSD).")
@click.pass_context
def call(ctx: click.Context, sender: str, to: str, kind: str) -> None:
    """Call TO from phone FROM.

    A data call prints the port of its bridge: connect a terminal there
    (or use "sondalog term gsm://API-HOST:PORT/TO?from=FROM" for an ALA1 session).
    """
    result = _run(_api(ctx).call, sender, to, kind)
    line = f"call {result['call']} {kind} {result['from']} -> {result['to']}: {result['state']}"
    if result.get("reason"):
        line += f" ({result['reason']})"
    click.echo(line)
    if "bridge" in result and result["state"] != "ended":
        click.echo(f"data bridge: tcp://127.0.0.1:{result['bridge']}")
