"""Mistakes in a site file's ``[gsm]`` and ``[mail]`` tables, one case per mistake: each is
refused with the exact ``FILE:LINE: field:`` prefix (the config reader names them)."""

from __future__ import annotations

from pathlib import Path

import pytest

from sondalog.app.gsm_site import parse_gsm_site
from sondalog.app.mailhub import parse_mail
from sondalog.config import ConfigError, loads

SITE = Path("site.toml")

GSM = """\
[gsm]
logger_modem = "+420600000001"
hosts = { "smtp.example.net" = "127.0.0.1" }

[gsm.serve]
api = "127.0.0.1:8125"

[[gsm.modem]]
number = "+420600000001"
signal = 18
store_size = 30

[gsm.modem.serve]
listen = "127.0.0.1:7001"

[[gsm.phone]]
number = "+420700000001"

[[gsm.outage]]
start = 1000
end = 2000
"""

MAIL = """\
[mail]
smtp = "127.0.0.1:2525"
pop3 = "127.0.0.1:1110"
smtp_auth_required = false

[mail.accounts]
"logger@example.net" = "secret"
"""


def _refused(text: str, change: tuple[str, str]) -> str:
    assert change[0] in text
    changed = text.replace(*change)
    with pytest.raises(ConfigError) as error:
        if changed.startswith("[gsm]"):
            parse_gsm_site(loads(changed, SITE))
        else:
            parse_mail(loads(changed, SITE).table("mail"), Path("state"))
    return str(error.value)


def test_the_good_files_pass() -> None:
    plan = parse_gsm_site(loads(GSM, SITE))
    assert plan.api == ("127.0.0.1", 8125) and plan.modems[0].listen == ("127.0.0.1", 7001)
    model = GSM.replace("signal = 18", 'signal = { model = "constant", value = 7.4 }')
    plan = parse_gsm_site(loads(model, SITE), 100.0)
    assert plan.config.modems[0].signal == 7 and plan.signals["+420600000001"](200.0) == 7.4
    assert parse_mail(loads(MAIL, SITE).table("mail"), Path("state")).smtp_port == 2525


@pytest.mark.parametrize(
    ("text", "change", "prefix"),
    [
        # a misspelt key in a [[gsm.modem]] table (and in its serve table, and in [gsm])
        (
            GSM,
            ("store_size = 30", "store_sise = 30"),
            "site.toml:11: gsm.modem[0].store_sise: unknown table or key 'store_sise' "
            "(did you mean store_size?",
        ),
        (
            GSM,
            ('listen = "127.0.0.1:7001"', 'lisen = "127.0.0.1:7001"'),
            "site.toml:14: gsm.modem[0].serve.lisen: unknown table or key 'lisen' "
            "(did you mean listen?",
        ),
        (GSM, ("[gsm.serve]", "[gsm.server]"), "site.toml:5: gsm.server: unknown table or key"),
        # type errors
        (GSM, ("signal = 18", 'signal = "18"'), "site.toml:10: gsm.modem[0].signal: must be"),
        (GSM, ("signal = 18", "signal = 40"), "site.toml:10: gsm.modem[0].signal: must be 0..31"),
        (GSM, ("store_size = 30", "store_size = true"), "site.toml:11: gsm.modem[0].store_size:"),
        (GSM, ("end = 2000", "end = 500"), "site.toml:21: gsm.outage[0].end: must be after start"),
        (
            GSM,
            ('"127.0.0.1" }', '"localhost" }'),
            "site.toml:3: gsm.hosts.smtp.example.net: must be an IPv4 address",
        ),
        (
            GSM,
            ("signal = 18", 'signal = { model = "sine", mean = 18 }'),
            "site.toml:10: gsm.modem[0].signal.amplitude: required",
        ),
        # bad listen addresses
        (GSM, ('api = "127.0.0.1:8125"', 'api = "8125"'), "site.toml:6: gsm.serve.api: expected"),
        (
            GSM,
            ('listen = "127.0.0.1:7001"', 'listen = "127.0.0.1:70001"'),
            "site.toml:14: gsm.modem[0].serve.listen: port must be a number 0..65535",
        ),
        (
            GSM,
            ('listen = "127.0.0.1:7001"', "listen = 7001"),
            'site.toml:14: gsm.modem[0].serve.listen: must be "HOST:PORT"',
        ),
        # the mail hub
        (MAIL, ('smtp = "127.0.0.1:2525"', 'smtp = "2525"'), "site.toml:2: mail.smtp: expected"),
        (MAIL, ("smtp = ", "smpt = "), "site.toml:2: mail.smpt: unknown table or key 'smpt'"),
        (
            MAIL,
            ("smtp_auth_required = false", 'smtp_auth_required = "no"'),
            "site.toml:4: mail.smtp_auth_required: must be true or false",
        ),
        (
            MAIL,
            ('"logger@example.net" =', "nobody ="),
            "site.toml:7: mail.accounts.nobody: 'nobody' is not an e-mail address",
        ),
    ],
)
def test_mistakes_are_refused_at_file_line_field(
    text: str, change: tuple[str, str], prefix: str
) -> None:
    assert _refused(text, change).startswith(prefix)
