"""[[alarm]] and [[notify]] through the config reader (issue 21): every kind, and every
refusal names file, line and field."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import pytest

from sondalog.collect.alarms import parse_alarms
from sondalog.collect.alarms.durations import parse_duration, parse_quiet, parse_rate
from sondalog.collect.alarms.outbox import Message
from sondalog.collect.alarms.send_email import EmailSettings
from sondalog.collect.alarms.send_log import LogSettings
from sondalog.collect.alarms.send_mqtt import MqttSettings
from sondalog.collect.alarms.send_sms import ModemSmsSettings, NetworkSmsSettings
from sondalog.collect.alarms.send_webhook import WebhookSettings
from sondalog.collect.alarms.senders import (
    _REGISTERED,
    COMMON_KEYS,
    known_kinds,
    register_sender,
    sender_for,
)
from sondalog.config import ConfigError, Table, loads

PATH = Path("/etc/collector.toml")
TO, PAGER = ("ops@example.net",), ("+420700000002",)

NOTIFY = """
[[notify]]
name = "ops-mail"
kind = "email"
smtp = "127.0.0.1:2525"
from = "collector@example.net"
to = ["ops@example.net"]
repeat = "4h"
quiet = "22:00-06:00"
rate = "5/h"

[[notify]]
name = "oncall-sms"
kind = "sms"
via = "network"
url = "http://127.0.0.1:8025"
from = "+420700000009"
number = "+420700000001"

[[notify]]
name = "pager"
kind = "sms"
via = "modem"
device = "/dev/ttyUSB0"
number = ["+420700000002"]

[[notify]]
name = "ha"
kind = "mqtt"
url = "mqtt://127.0.0.1:1883"
discovery = true

[[notify]]
name = "hook"
kind = "webhook"
url = "https://example.net/hook"
secret = "s3cret"
retries = 8

[[notify]]
name = "log"
kind = "log"
"""


def plan(text: str):  # type: ignore[no-untyped-def]
    return parse_alarms(loads(NOTIFY + text, PATH))


def refused(text: str) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        plan(text)
    return info.value


def test_every_kind_is_read() -> None:
    p = plan(
        """
[[alarm]]
kind = "threshold"
logger = "F*"
channel = "Air"
above = 40
clear = 38
for = 3
notify = ["ops-mail", "oncall-sms"]

[[alarm]]
kind = "no_contact"
source = "station-*"
after = "30m"

[[alarm]]
kind = "stuck"
channel = 2
for = 6

[[alarm]]
kind = "step"
channel = 1
step = 5.5

[[alarm]]
name = "low battery"
kind = "health"
measure = "supply"
below = 11.5
clear = 12

[[alarm]]
kind = "health"
measure = "gaps"

[[alarm]]
kind = "collector"
watch = "buffer"
sink = "postgres"
above = 100

[[alarm]]
kind = "collector"
watch = "sink"
after = 120

[[alarm]]
kind = "collector"
watch = "source"
for = 5
"""
    )
    kinds = [r.kind for r in p.rules]
    assert (
        kinds
        == ["threshold", "no_contact", "stuck", "step", "health", "health"] + ["collector"] * 3
    )
    t = p.rules[0]
    assert (t.logger, t.channel_name, t.direction, t.limit, t.clear, t.count) == (
        "F*",
        "Air",
        "above",
        40,
        38,
        3,
    )
    assert t.notify == ("ops-mail", "oncall-sms")
    assert t.name == "threshold F*/Air above 40" and t.line is not None
    assert p.rules[1].after == 1800.0
    assert p.rules[2].channel == 2 and p.rules[2].count == 6
    assert p.rules[3].step == 5.5
    assert p.rules[4].name == "low battery" and p.rules[4].direction == "below"
    assert (p.rules[5].measure, p.rules[5].limit) == ("gaps", 0.0)
    assert (p.rules[6].watch, p.rules[6].limit, p.rules[6].sink) == ("buffer", 100, "postgres")
    assert p.rules[7].after == 120
    assert p.rules[8].count == 5
    mail = p.notify["ops-mail"]
    assert mail.settings == EmailSettings(("127.0.0.1", 2525), "collector@example.net", TO)
    assert mail.repeat == 4 * 3600
    assert mail.rate is not None and (mail.rate.count, mail.rate.per) == (5, 3600)
    assert str(mail.quiet[0]) == "22:00-06:00"
    assert p.notify["pager"].settings == ModemSmsSettings(Path("/dev/ttyUSB0"), PAGER, 9600)
    assert p.notify["oncall-sms"].settings == NetworkSmsSettings(
        "http://127.0.0.1:8025", "+420700000009", ("+420700000001",)
    )
    assert p.notify["hook"].retries == 8
    assert p.notify["hook"].settings == WebhookSettings("https://example.net/hook", "s3cret")
    assert p.notify["ha"].settings == MqttSettings("mqtt://127.0.0.1:1883")
    assert p.notify["log"].settings == LogSettings(logging.WARNING)


@pytest.mark.parametrize(
    ("text", "where", "words"),
    [
        ('kind = "threshold"\nabove = 1\nfor = 0', "alarm[0].for", "readings >= 1"),
        ('kind = "threshold"\nabove = 1\nfro = 2', "alarm[0].fro", "did you mean for?"),
        ('kind = "threshold"\nabove = 1\nbelow = 0', "alarm[0].below", "exactly one"),
        ('kind = "threshold"', "alarm[0]", "exactly one"),
        ('kind = "threshold"\nabove = 5\nclear = 6', "alarm[0].clear", "hysteresis"),
        ('kind = "threshold"\nabove = 1\nnotify = ["ops-mial"]', "alarm[0].notify", "ops-mail"),
        ('kind = "stuck"\nafter = 5', "alarm[0].after", "unknown"),
        ('kind = "no_contact"\nafter = "5 parsecs"', "alarm[0].after", "duration"),
        ('kind = "no_contact"\nafter = -1', "alarm[0].after", "seconds > 0"),
        ('kind = "tresh"', "alarm[0].kind", "must be one of"),
        ('kind = "health"\nmeasure = "supply"\nabove = 3', "alarm[0].above", "use below"),
        ('kind = "health"\nmeasure = "memory"\nabove = 90', "alarm[0].above", "ratio"),
        ('kind = "collector"\nwatch = "sink"\nabove = 3', "alarm[0].above", "not used"),
        ('kind = "step"\nchannel = 0\nstep = 1', "alarm[0].channel", "channel number"),
        ('kind = "step"\nchannel = true\nstep = 1', "alarm[0].channel", "channel number"),
    ],
)
def test_refusals_name_file_line_and_field(text: str, where: str, words: str) -> None:
    error = refused("\n[[alarm]]\n" + text + "\n")
    assert error.field == where, error
    assert words in str(error)
    assert str(error).startswith(f"{PATH}:")
    assert error.line is not None and error.line > NOTIFY.count("\n")


def test_two_rules_with_one_name_are_refused() -> None:
    text = '\n[[alarm]]\nkind = "step"\nstep = 1\n' * 2
    error = refused(text)
    assert error.field == "alarm[1]" and "give each rule its own name" in str(error)


@pytest.mark.parametrize(
    ("text", "where", "words"),
    [
        ('name = "x"\nkind = "email"\nsmtp = "h:1"\nfrom = "a@b"\nto = "nobody"', "to", "e-mail"),
        ('name = "x"\nkind = "email"\nsmtp = "nohost"\nfrom = "a@b"\nto = "a@b"', "smtp", ""),
        ('name = "x"\nkind = "sms"\nvia = "modem"\nurl = "http://h"\nnumber = "+1234"', "url", ""),
        (
            'name = "x"\nkind = "sms"\nvia = "network"\nurl = "http://h"\nnumber = "12"',
            "number",
            "",
        ),
        (
            'name = "x"\nkind = "sms"\nvia = "network"\nurl = "http://h"\nnumber = "+1234"',
            "from",
            "",
        ),
        (
            'name = "x"\nkind = "sms"\nvia = "network"\nurl = "http://h"\nfrom = "+1234"\n'
            'number = "+1234"\nbaud = 9600',
            "baud",
            "modem",
        ),
        (
            'name = "x"\nkind = "sms"\nvia = "modem"\ndevice = "/dev/x"\nnumber = "+1234"\n'
            "baud = 0",
            "baud",
            "",
        ),
        ('name = "x"\nkind = "webhook"\nurl = "ftp://h"', "url", "http"),
        ('name = "x"\nkind = "log"\nrate = "5 per hour"', "rate", "COUNT/DURATION"),
        ('name = "x"\nkind = "log"\nquiet = ["25:00-06:00"]', "quiet", "no such time"),
        ('name = "x"\nkind = "log"\ntimezone = "Mars/Olympus"', "timezone", "time zone"),
        ('name = "x"\nkind = "log"\nlevle = "info"', "levle", "did you mean level"),
        ('name = "ops-mail"\nkind = "log"', "name", "another"),
        ('name = "x"\nkind = "log"\nbackoff = 60\nbackoff_max = 30', "backoff_max", "at least"),
        # every kind's own mistakes, found by the parse registered with its sender
        ('name = "x"\nkind = "pager"', "kind", "must be one of"),
        ('name = "x"\nkind = "log"\nlevel = "loud"', "level", "must be one of"),
        ('name = "x"\nkind = "log"\nurl = "http://h"', "url", "unknown"),
        ('name = "x"\nkind = "email"\nsmtp = "h:1"\nfrom = "me"\nto = "a@b"', "from", "e-mail"),
        ('name = "x"\nkind = "email"\nsmtp = "h:1"\nfrom = "a@b"', "to", "required"),
        ('name = "x"\nkind = "email"\nsmtp = "h:1"\nfrom = "a@b"\nto = []', "to", ""),
        ('name = "x"\nkind = "email"\nsmtp = "h:1"\nfrom = "a@b"\ntoo = "a@b"', "too", "to?"),
        (
            'name = "x"\nkind = "email"\nsmtp = "h:1"\nfrom = "a@b"\nto = "a@b"\nuser = 5',
            "user",
            "string",
        ),
        ('name = "x"\nkind = "sms"\nvia = "pigeon"\nnumber = "+1234"', "via", "must be one of"),
        ('name = "x"\nkind = "sms"\nvia = "modem"\nnumber = "+1234"', "device", "required"),
        ('name = "x"\nkind = "mqtt"\nurl = "http://h"', "url", "mqtt://"),
        ('name = "x"\nkind = "mqtt"\nurl = "mqtt://h"\ntopic = "a/#"', "topic", "topic"),
        ('name = "x"\nkind = "mqtt"\nurl = "mqtt://h"\ndiscovery = "yes"', "discovery", ""),
        ('name = "x"\nkind = "mqtt"\nurl = "mqtt://h"\nsecret = "s"', "secret", "unknown"),
        ('name = "x"\nkind = "webhook"\nurl = "http://h"\ntimeout = 0', "timeout", ""),
        ('name = "x"\nkind = "webhook"\nurl = "http://h"\nsecret = 1', "secret", "string"),
        ('name = "x"\nkind = "webhook"', "url", "required"),
    ],
)
def test_notify_refusals(text: str, where: str, words: str) -> None:
    error = refused("\n[[notify]]\n" + text + "\n")
    assert error.field == f"notify[6].{where}", error
    assert words in str(error)
    assert error.line is not None


@dataclass(frozen=True)
class PigeonSettings:
    loft: str


def _pigeon(t: Table) -> PigeonSettings:
    t.keys(COMMON_KEYS | {"loft"})
    return PigeonSettings(t.text("loft", pattern=r"[a-z]+", what="a loft"))


class _Pigeon:
    def __init__(self, settings: PigeonSettings) -> None:
        self.loft = settings.loft

    async def send(self, message: Message) -> None:
        return None

    async def close(self) -> None:
        return None


def test_a_kind_registered_elsewhere_parses_its_own_settings() -> None:
    """A destination kind is one register_sender call: its parse reads its keys (with
    file, line and field), its factory gets the typed settings."""
    register_sender("pigeon", lambda notify: _Pigeon(notify.settings), _pigeon)
    try:
        text = '\n[[notify]]\nname = "coop"\nkind = "pigeon"\nloft = "north"\nrepeat = "1h"\n'
        coop = plan(text).notify["coop"]
        assert coop.settings == PigeonSettings("north") and coop.repeat == 3600
        sender = sender_for(coop)
        assert isinstance(sender, _Pigeon) and sender.loft == "north"
        error = refused(text.replace("north", "North"))
        assert error.field == "notify[6].loft" and "a loft" in str(error)
        assert str(error).startswith(f"{PATH}:{NOTIFY.count(chr(10)) + 5}:")
    finally:
        _REGISTERED.pop("pigeon")
    assert "pigeon" not in known_kinds()


def test_no_tables_is_an_empty_plan() -> None:
    p = parse_alarms(loads("", PATH))
    assert p.rules == () and p.notify == {}


def test_small_syntaxes() -> None:
    assert parse_duration("1h30m") == 5400 and parse_duration("90s") == 90
    assert parse_rate("10/30m").per == 1800 and parse_rate("3/h").count == 3
    q = parse_quiet("22:00-06:00")
    assert (q.start.hour, q.end.hour) == (22, 6)
    for bad in ("", "1x", "h", "0s"):
        with pytest.raises(ValueError):
            parse_duration(bad)
    with pytest.raises(ValueError):
        parse_quiet("06:00-06:00")


def test_the_examples_of_the_manual_are_read() -> None:
    """Every ```toml block of docs/alarms.md, together, is a valid set of rules."""
    doc = (Path(__file__).resolve().parents[3] / "docs" / "alarms.md").read_text()
    blocks = [part.split("```", 1)[0] for part in doc.split("```toml\n")[1:]]
    p = parse_alarms(loads("\n".join(blocks), PATH))
    assert {r.kind for r in p.rules} == {
        "no_contact",
        "threshold",
        "stuck",
        "step",
        "health",
        "collector",
    }
    assert {n.kind for n in p.notify.values()} == {"email", "sms", "mqtt", "webhook", "log"}
