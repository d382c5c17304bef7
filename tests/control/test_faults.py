"""Faults of the control API, each observed from outside: the logger's answers show it."""

from __future__ import annotations

import asyncio
import smtplib
import time
from email.message import EmailMessage
from pathlib import Path

import pytest
from control_site import Site, http, served
from test_inputs_time import read, setup


async def rom_of(site: Site) -> str:
    inputs = (await site.get("/devices/logger"))["inputs"]
    return next(k for k in inputs if k.startswith("ds18b20:"))


def test_sensor_faults_disconnected_stuck_85_and_bad_crc(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            rom = await rom_of(site)
            assert await read(site, "read channel 1 value") == "1.00"
            await site.post("/devices/logger/fault", {"kind": "disconnected", "input": "analog:16"})
            assert await read(site, "read channel 1 value") == ""  # no valid value
            assert (await site.get("/devices/logger"))["inputs"]["analog:16"] is None
            await site.post("/devices/logger/clear", {"input": "analog:16"})
            assert await read(site, "read channel 1 value") == "1.00"
            # stuck: the world changes, the reading does not
            await site.post("/devices/logger/fault", {"kind": "stuck", "input": "analog:16"})
            await site.post("/devices/logger/fault", {"kind": "stuck", "input": "supply"})
            await site.post("/devices/logger/set", {"input": "analog:16", "value": 2.0}, 409)
            assert await read(site, "read channel 1 value") == "1.00"
            await site.post("/devices/logger/clear", {"kind": "stuck"})
            # the DS18B20: 21.5 °C, then its power-on value 85 °C, then a bad CRC: no value
            assert await read(site, "read channel 2 value") == "21.50"
            await site.post("/devices/logger/fault", {"kind": "power_on_reset", "input": rom})
            assert await read(site, "read channel 2 value") == "85.00"
            await site.post("/devices/logger/clear", {})
            await site.post("/devices/logger/fault", {"kind": "bad_crc", "input": rom})
            assert await read(site, "read channel 2 value") == ""
            await site.post("/devices/logger/clear", {"kind": "bad_crc"})
            assert await read(site, "read channel 2 value") == "21.50"

    asyncio.run(main())


def test_a_fault_with_a_duration_ends_when_the_clock_has_run_that_long(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            body = {"kind": "disconnected", "input": "analog:16", "duration": 600}
            await site.post("/devices/logger/fault", body)
            await site.post("/time/step", {"seconds": 599})
            assert await read(site, "read channel 1 value") == ""
            await site.post("/time/step", {"seconds": 1})
            for _ in range(100):  # the expiry runs on the event loop right after the step
                if not (await site.get("/devices/logger"))["faults"]:
                    break
                await asyncio.sleep(0.01)
            assert await read(site, "read channel 1 value") == "1.00"

    asyncio.run(main())


def test_power_loss_keeps_every_acknowledged_write_and_the_record(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            await site.ask("write channel 1 sampling period 000100")
            await site.ask("write channel 1 sampling start 20070301090000")
            await site.post("/time/step", {"seconds": 600})
            before = await site.ask("read record 100 from start")
            assert len(before.splitlines()) == 10
            answer = await site.post("/devices/logger/fault", {"kind": "power_loss"})
            assert answer["powered"] is False
            # no answer while it has no power; nothing sampled
            loop = asyncio.get_running_loop()
            reader, writer = await asyncio.open_connection(*site.running.logger.servers[0].address)
            writer.write(b"read date\r")
            await site.post("/time/step", {"seconds": 600})
            try:
                got = await asyncio.wait_for(reader.read(100), 0.3)
            except TimeoutError:
                got = b""
            assert got == b""
            started = loop.time()
            answer = await site.post("/devices/logger/clear", {"kind": "power_loss"})
            assert (await site.get("/devices/logger"))["powered"]
            assert loop.time() - started < 2
            # the connection made before the power loss works again, with new line state
            writer.write(b"read channel 1 sampling period\r")
            assert await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 5) == b"000100\r\nOK\r\n"
            writer.close()
            after = await site.ask("read record 100 from start")
            assert after == before  # the record, and no rows for the 10 minutes without power
            assert await site.ask("read date") == "20070301091959"  # its clock ran on
            await site.post("/time/step", {"seconds": 60})
            assert len((await site.ask("read record 100 from start")).splitlines()) == 11
            assert (await site.get("/devices/logger"))["restarts"] == 1

    asyncio.run(main())


def test_brownout_shows_in_the_supply_and_below_the_reset_voltage_restarts(
    tmp_path: Path,
) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            assert await read(site, "read channel 3 value") == "12.0"
            await site.post("/devices/logger/fault", {"kind": "brownout", "volts": 7.5})
            assert await read(site, "read channel 3 value") == "7.5"
            await site.post("/devices/logger/clear", {})
            assert await read(site, "read channel 3 value") == "12.0"
            answer = await site.post("/devices/logger/fault", {"kind": "brownout", "volts": 3})
            assert answer["powered"] is False
            await site.post("/devices/logger/clear", {"kind": "brownout"})
            device = await site.get("/devices/logger")
            assert device["powered"] and device["restarts"] == 1
            assert await read(site, "read channel 3 value") == "12.0"

    asyncio.run(main())


def test_clock_jump(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            assert await site.ask("read date") == "20070301085959"
            await site.post("/devices/logger/fault", {"kind": "clock_jump", "seconds": 3600})
            assert await site.ask("read date") == "20070301095959"
            await site.post("/devices/logger/fault", {"kind": "clock_jump", "seconds": -7200})
            assert await site.ask("read date") == "20070301075959"
            assert (await site.get("/devices/logger"))["faults"] == []  # it happened once

    asyncio.run(main())


def test_a_cut_line_and_a_slow_line(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            address = site.running.logger.servers[0].address
            reader, writer = await asyncio.open_connection(*address)
            await site.post("/devices/logger/fault", {"kind": "cut"})
            writer.write(b"read i version\r")
            try:
                got = await asyncio.wait_for(reader.read(100), 0.3)
            except TimeoutError:
                got = b""
            assert got == b""
            await site.post("/devices/logger/clear", {"kind": "cut"})
            writer.write(b"read i version\r")
            clean = await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 5)
            # 300 baud: 30 bytes a second, after 0.2 s; the clock runs (slow is line time)
            await site.post("/time/resume")
            await site.post("/devices/logger/fault", {"kind": "slow", "baud": 300, "latency": 0.2})
            started = time.monotonic()
            writer.write(b"read i version\r")
            assert await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 10) == clean
            took = time.monotonic() - started
            assert took >= 0.2 + len(clean) / 30 - 0.05, took
            await site.post("/devices/logger/clear", {})
            started = time.monotonic()
            writer.write(b"read i version\r")
            assert await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 5) == clean
            assert time.monotonic() - started < 0.2
            writer.close()

    asyncio.run(main())


GSM = """
[gsm]
smsc = "+420603052000"

[gsm.serve]
api = "127.0.0.1:0"

[[gsm.modem]]
number = "+420600000001"

[gsm.modem.serve]
listen = "127.0.0.1:0"

[[gsm.phone]]
number = "+420700000001"
"""


def test_a_modem_without_coverage_as_the_network_sees_it(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path, GSM) as site:
            assert site.running.gsm_api is not None
            api = site.running.gsm_api.address[1]

            async def covered() -> dict[str, bool]:
                status, subscribers = await http(api, "GET", "/subscribers")
                assert status == 200
                return {s["number"]: s["covered"] for s in subscribers}

            assert [d["name"] for d in await site.get("/devices")] == ["gsm"]
            body = {"kind": "no_coverage", "number": "+420600000001"}
            answer = await site.post("/devices/gsm/fault", body)
            assert answer["fault"]["number"] == "+420600000001"
            assert await covered() == {"+420600000001": False, "+420700000001": True}
            await site.post("/devices/gsm/fault", body, 409)
            await site.post("/devices/gsm/fault", {"kind": "no_coverage", "number": "+1555"}, 404)
            await site.post("/devices/gsm/fault", {"kind": "cut"}, 400)
            await site.post("/devices/gsm/clear", {})
            assert await covered() == {"+420600000001": True, "+420700000001": True}
            await site.post("/devices/gsm/fault", {"kind": "no_coverage"})  # everyone
            assert set((await covered()).values()) == {False}
            await site.post("/devices/gsm/clear", {"kind": "no_coverage"})
            assert set((await covered()).values()) == {True}

    asyncio.run(main())


MAIL = """
[mail]
smtp = "127.0.0.1:0"
pop3 = "127.0.0.1:0"

[mail.accounts]
"logger@example.net" = "secret"
"""


def _send_mail(port: int) -> None:
    message = EmailMessage()
    message["From"], message["To"], message["Subject"] = "a@b.c", "logger@example.net", "x"
    message.set_content("data")
    with smtplib.SMTP("127.0.0.1", port, timeout=10) as smtp:
        smtp.send_message(message)


def test_an_smtp_server_refusing(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path, MAIL) as site:
            assert site.running.mail is not None
            port = site.running.mail.smtp_port
            await asyncio.to_thread(_send_mail, port)  # taken
            await site.post("/devices/mail/fault", {"kind": "smtp_refusing"})
            with pytest.raises(smtplib.SMTPRecipientsRefused) as refused:
                await asyncio.to_thread(_send_mail, port)
            assert refused.value.recipients["logger@example.net"][0] == 451
            await site.post("/devices/mail/clear", {})
            body = {"kind": "smtp_refusing", "code": 554, "duration": 60}
            await site.post("/devices/mail/fault", body)
            with pytest.raises(smtplib.SMTPRecipientsRefused) as refused:
                await asyncio.to_thread(_send_mail, port)
            assert refused.value.recipients["logger@example.net"][0] == 554
            await site.post("/time/step", {"seconds": 60})
            for _ in range(100):
                if not (await site.get("/devices"))[0]["faults"]:
                    break
                await asyncio.sleep(0.01)
            await asyncio.to_thread(_send_mail, port)  # the fault ended by itself
            maildir = site.running.mail.maildir("logger@example.net") / "new"
            assert len(list(maildir.iterdir())) == 2

    asyncio.run(main())
