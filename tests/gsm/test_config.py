"""The ``[gsm]`` table of a site file: the example world builds, mistakes name their field."""

from __future__ import annotations

import pytest

from sondalog.config import ConfigError, loads
from sondalog.gsm.config import build, parse

WORLD = """
[gsm]
hosts = { "smtp.example.net" = "127.0.0.1", "pop3.example.net" = "127.0.0.1" }

[[gsm.modem]]
number = "+420600000001"
credit = 250.00
publish = { "10001" = 20001 }

[[gsm.phone]]
number = "+420700000001"

[[gsm.phone]]
number = "00420 700 000 002"

[[gsm.outage]]
start = 1000
end = 2000
number = "+420700000002"
"""


def test_example_world_builds() -> None:
    config = parse(loads(WORLD).table("gsm"))
    system = build(config, 0.0)
    net = system.network
    assert set(net.subscribers) == {"+420600000001", "+420700000001", "+420700000002"}
    assert net.gateway.resolve("SMTP.example.net") == "127.0.0.1"
    assert net.gateway.host_port("+420600000001", 10001) == 20001
    modem = system.modems["+420600000001"]
    assert modem.registered
    reply = system.modem_input("+420600000001", b'ATE0;+CUSD=1,"*101#",15\r', 0.0)
    assert reply.line("+420600000001").endswith(b'\r\n+CUSD: 0,"Your credit is 250.00 CZK.",15\r\n')
    assert system.next_deadline(0.0) == 1000


@pytest.mark.parametrize(
    ("toml", "field"),
    [
        ("[gsm]\ncolour = 1", "gsm.colour"),
        ('[[gsm.modem]]\nnumber = "12ab"', "gsm.modem[0].number"),
        ('[[gsm.modem]]\nnumber = "+420600000001"\nsignal = 40', "gsm.modem[0].signal"),
        ('[[gsm.modem]]\nnumber = "+420600000001"\npublish = { "x" = 1 }', "gsm.modem[0].publish"),
        (
            '[[gsm.modem]]\nnumber = "+420600000001"\nussd = { "*1#" = "{x}" }',
            'gsm.modem[0].ussd."*1#"',
        ),
        (
            '[[gsm.phone]]\nnumber = "+420700000001"\n[[gsm.phone]]\nnumber = "+420700000001"',
            "gsm.phone[1].number",
        ),
        ("[[gsm.outage]]\nstart = 5\nend = 1", "gsm.outage[0].end"),
        ('[gsm]\nhosts = { "a" = 5 }', "gsm.hosts.a"),
        ('[[gsm.modem]]\nnumber = "+420600000001"\ncredit = "lots"', "gsm.modem[0].credit"),
    ],
)
def test_mistakes_name_their_field(toml: str, field: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse(loads(toml).table("gsm"))
    assert caught.value.field == field
