"""The GSM cores as Devices (world/gsm_devices.py) and the [gsm] site table as served
(app/gsm_site.py): pure, on a stepped time."""

from __future__ import annotations

from pathlib import Path

import pytest

from sondalog.app.gsm_site import parse_gsm_site
from sondalog.config import ConfigError, loads
from sondalog.gsm import events as ev
from sondalog.gsm.gateway import ModemEvent
from sondalog.gsm.modem import Modem
from sondalog.gsm.network import Network
from sondalog.protocol.device import LineSend
from sondalog.world.gsm_devices import (
    FromNetwork,
    ModemDevice,
    ModemSaid,
    NetworkDevice,
    NetworkSaid,
    ToNetwork,
)

T0 = 1_764_460_800.0
NUMBER = "+420600000001"


def to_modem(number: str, event: ev.Event) -> NetworkSaid:
    """The network device's effect carrying an event for a modem."""
    return NetworkSaid(ModemEvent(number, event))


def test_modem_device_answers_every_line_and_speaks_to_the_network() -> None:
    device = ModemDevice(NUMBER, Modem())
    a, b = device.open_line(), device.open_line(paced=True)
    effects = device.receive(a, b"ATE0\r", T0)
    assert [e for e in effects if isinstance(e, LineSend)] == [LineSend(a, b"ATE0\r\r\nOK\r\n")]
    # the paced line carries the same bytes at 9600 baud: 11 bytes take 11.5 ms
    due = device.next_deadline()
    assert due is not None and T0 < due <= T0 + 0.02
    paced = b"".join(
        e.data for e in device.advance(T0 + 0.02) if isinstance(e, LineSend) and e.line == b
    )
    assert paced == b"ATE0\r\r\nOK\r\n"
    device.close_line(b)
    effects = device.receive(a, b"AT+CFUN=0\r", T0)
    assert LineSend(a, b"\r\nOK\r\n") in effects and ToNetwork(NUMBER, ev.Radio(False)) in effects
    assert not any(isinstance(e, LineSend) and e.line == b for e in effects)
    effects = device.handle(FromNetwork(ev.Registration(True)), T0)
    assert effects == []  # AT+CREG=0: no URC
    assert device.line_speed() == 9600


def test_network_device_routes_and_follows_the_models() -> None:
    network = Network()
    network.add_modem(NUMBER, T0, credit=100.0)
    network.sms_price = 1.5
    device = NetworkDevice(
        network, T0, signals={NUMBER: lambda t: 10 + (t - T0)}, credits={NUMBER: lambda t: 100.0}
    )
    assert device.next_deadline() == T0
    effects = device.advance(T0)
    assert to_modem(NUMBER, ev.Signal(10)) in effects
    assert device.next_deadline() == T0 + 1.0
    assert device.advance(T0 + 1.0) == [to_modem(NUMBER, ev.Signal(11))]
    device.handle(ModemSaid(NUMBER, ev.SendSms("+420700000001", "x", 1)), T0 + 1.5)
    assert network.subscriber(NUMBER).credit == 98.5
    device.advance(T0 + 2.0)  # the model says 100, the network took 1.5 for the SMS
    assert network.subscriber(NUMBER).credit == 98.5
    effects = device.handle(ModemSaid(NUMBER, ev.Ussd("*101#")), T0 + 2.5)
    assert effects == [to_modem(NUMBER, ev.UssdAnswer("Your credit is 98.50 CZK."))]


SITE = """
[logger.gsm]
signal = { model = "constant", value = 7 }
credit = { model = "ramp", start = 50, rate = -1 }

[gsm]
logger_modem = "+420600000001"
[gsm.serve]
api = "127.0.0.1:8125"
[[gsm.modem]]
number = "+420600000001"
[gsm.modem.serve]
pty = "/tmp/x-modem"
listen = "127.0.0.1:0"
trace = "t.trace"
[[gsm.phone]]
number = "+420700000001"
"""


def _plan(text: str, start: float = T0) -> object:
    return parse_gsm_site(loads(text, Path("site.toml")), start)


def test_site_table_with_serve_keys_and_logger_models() -> None:
    plan = parse_gsm_site(loads(SITE, Path("site.toml")), T0)
    assert plan.api == ("127.0.0.1", 8125)
    (modem,) = plan.modems
    assert (modem.pty, modem.listen, modem.trace) == (
        Path("/tmp/x-modem"),
        ("127.0.0.1", 0),
        Path("t.trace"),
    )
    assert plan.logger_modem == NUMBER
    assert plan.signals[NUMBER](T0) == 7 and plan.credits[NUMBER](T0 + 10) == 40


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (('api = "127.0.0.1:8125"', 'api = "nowhere"'), "gsm.serve.api"),
        (('api = "127.0.0.1:8125"', "port = 1"), "gsm.serve.port"),
        (('trace = "t.trace"', "baud = 1"), "gsm.modem[0].serve.baud"),
        (('logger_modem = "+420600000001"', 'logger_modem = "+420600000009"'), "gsm.logger_modem"),
        (('number = "+420700000001"', 'number = "+420600000001"'), "gsm.phone[0].number"),
    ],
)
def test_site_table_errors_name_the_field(change: tuple[str, str], field: str) -> None:
    text = SITE.replace(*change)
    with pytest.raises(ConfigError) as error:
        _plan(text)
    assert field in str(error.value)


def test_runtime_dte_link_in_process(tmp_path: Path) -> None:
    """The wiring's hook for the logger's com line: an in-process DTE line of a modem."""
    import asyncio

    from sondalog.app.gsm import GsmRuntime
    from sondalog.io.clock import RealClock

    text = SITE.replace('pty = "/tmp/x-modem"\n', "").replace('listen = "127.0.0.1:0"\n', "")
    plan = parse_gsm_site(loads(text, tmp_path / "site.toml"), T0)

    async def run() -> bytes:
        runtime = GsmRuntime(plan, tmp_path / "gsm", RealClock())
        await runtime.start()
        got = bytearray()
        try:
            link = runtime.dte(NUMBER, got.extend)
            link.write(b"ATE0\rAT+CSQ\r")
            for _ in range(100):
                if got.endswith(b"OK\r\n") and b"+CSQ" in got:
                    break
                await asyncio.sleep(0.01)
        finally:
            await runtime.close()
        return bytes(got)

    assert asyncio.run(run()) == b"ATE0\r\r\nOK\r\n\r\n+CSQ: 7,0\r\n\r\nOK\r\n"
    assert "logger>modem  ATE0\\r" in (tmp_path / "gsm" / "t.trace").read_text()
    assert (tmp_path / "gsm" / "network.json").exists()


def test_network_device_wakes_for_a_scheduled_outage() -> None:
    network = Network()
    network.add_modem(NUMBER, T0)
    network.schedule_outage(T0 + 10, T0 + 20, NUMBER)
    device = NetworkDevice(network, T0)
    assert device.next_deadline() == T0 + 10
    assert to_modem(NUMBER, ev.Registration(False)) in device.advance(T0 + 10)
    assert device.next_deadline() == T0 + 20
    assert to_modem(NUMBER, ev.Registration(True)) in device.advance(T0 + 20)
    assert device.next_deadline() is None
