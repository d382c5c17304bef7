"""Integration: real ``sondalog bus serve`` subprocesses over real TCP and a real pty."""

from __future__ import annotations

import asyncio
import os
import select
from pathlib import Path

from bus_helpers import ServedBus, sondalog

from sondalog.client.bus import BusMaster
from sondalog.hctmps1 import encode_frame


def test_kill_9_after_saveee_keeps_saved_settings_only(tmp_path: Path) -> None:
    state = tmp_path / "state"

    async def configure(url: str) -> None:
        async with await BusMaster.open(url) as m:
            assert await m.connect("T1", "0000")
            assert await m.addsup("T1", "L1")
            assert await m.newpw("T1", "s3cret")
            assert await m.setmid("T1", "T5")
            await m.saveee("T5")  # the reply means: on disk
            # Changed after the save: must not survive the kill.
            assert await m.addp("T5", "LOST")
            assert await m.addsup("T5", "L2")
            assert await m.newpw("T5", "other")
            assert await m.csservon("T5", "PC")

    with ServedBus(state) as served:
        asyncio.run(configure(served.url))
        served.proc.kill()  # SIGKILL: no chance to flush anything
        served.proc.wait(timeout=10)

    async def check(url: str) -> None:
        async with await BusMaster.open(url) as m:
            assert await m.hello("T5") == "HCTMPS1-temp server (DS18B20)"
            assert await m.hello("H1") == "HCTMPS1-hum server (SHT11)"
            assert not await m.connect("T5", "other")
            assert await m.connect("T5", "s3cret")
            assert await m.listsup("T5") == ["L1"]
            assert await m.listp("T5") is None
            assert await m.csservlist("T5") == []

    with ServedBus(state) as served:
        asyncio.run(check(served.url))
        assert served.terminate() == 0


def test_cli_session_over_tcp(tmp_path: Path) -> None:
    with ServedBus(tmp_path / "state", "--speed", "5") as served:
        url = served.url
        hello = sondalog("bus", "ask", url, "T1", "HELLO")
        assert (hello.returncode, hello.stdout) == (0, "RHELLO.HCTMPS1-temp server (DS18B20)\n")
        pv = sondalog("bus", "ask", url, "H1", "PV")
        assert pv.returncode == 0 and pv.stdout.startswith("RPV.")
        silent = sondalog("bus", "ask", url, "T1", "LISTSUP", "--timeout", "0.2")
        assert silent.returncode == 1 and "no reply" in silent.stderr
        config = sondalog(
            "bus", "config", url, "T1", "--add-supervisor", "L1", "--symbol", "TEMP1", "--save"
        )
        assert config.returncode == 0, config.stderr
        assert config.stdout.splitlines() == [
            "CONNECT T1: <OK>",
            "ADDSUP L1: <OK>",
            "ADDP TEMP1: <OK>",
            "SAVEEE: <OK>",
            "DISCONNECT T1: <OK>",
        ]
        scan = sondalog("bus", "scan", url)
        assert scan.returncode == 0
        assert scan.stdout.splitlines() == [
            "H1       HCTMPS1-hum server (SHT11)",
            "T1       HCTMPS1-temp server (DS18B20)",
        ]
        watch = sondalog("bus", "watch", url, "--module", "H1", "--count", "2")
        assert watch.returncode == 0, watch.stderr
        lines = watch.stdout.splitlines()
        assert len(lines) == 2 and all(" H1 -> PC " in line for line in lines)
        mode = sondalog("bus", "ask", url, "H1", "GETMODE")
        assert mode.stdout == "RGETMODE.MDISOF\n"  # watch turned it off again
        assert served.terminate() == 0


def test_bad_input_exits_with_2(tmp_path: Path) -> None:
    assert sondalog("bus", "ask", "ftp://x", "T1", "HELLO").returncode == 2
    assert sondalog("bus", "ask", "tcp://127.0.0.1:1", "bad id", "HELLO").returncode == 2
    assert sondalog("bus", "ask", "tcp://127.0.0.1:1", "T1", "A|B").returncode == 2
    assert sondalog("bus", "config", "tcp://127.0.0.1:1", "T1", "--set-id", "*").returncode == 2
    assert sondalog("bus", "serve", "--listen", "nope").returncode == 2
    site = tmp_path / "site.toml"
    site.write_text('[bus]\n\n[[bus.modules]]\nid = "T1"\nkind = "pressure"\n')
    bad = sondalog("bus", "serve", "--listen", "127.0.0.1:0", "--site", str(site))
    assert bad.returncode == 2
    assert f"{site}:5: bus.modules[0].kind" in bad.stderr


def test_pty_with_a_stable_symlink(tmp_path: Path) -> None:
    link = tmp_path / "bus0"
    with ServedBus(tmp_path / "state", "--pty", str(link)) as served:
        assert link.is_symlink() and os.readlink(link).startswith("/dev/pts/")

        async def talk() -> tuple[str, float, list[str]]:
            async with await BusMaster.open(f"serial://{link}?baud=9600") as m:
                return await m.hello("H1"), await m.pv("T1"), list(await m.scan())

        hello, value, found = asyncio.run(talk())
        assert hello == "HCTMPS1-hum server (SHT11)"
        assert -55 <= value <= 125
        assert found == ["H1", "T1"]
        # The CLI reaches the same pty through the serial URL form.
        ask = sondalog("bus", "ask", f"serial://{link}?baud=9600", "T1", "GETVER")
        assert ask.stdout == "RGETVER.HVER*1_00*V-2013.SVER*1_1*VI-2018\n"
        assert served.terminate() == 0
    assert not link.exists()


def test_site_file_modules_and_tcp_hosts_hear_each_other(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    (tmp_path / "hum.csv").write_text("time,value\n0,40\n3600,60\n")
    site.write_text(
        """
[bus]
seed = 7

[[bus.modules]]
id = "TA"
kind = "temp"
signal = { model = "constant", value = 19.9 }

[[bus.modules]]
id = "HB"
kind = "hum"
[bus.modules.signal]
model = "csv"
path = "hum.csv"
"""
    )
    with ServedBus(tmp_path / "state", "--site", str(site)) as served:

        async def talk() -> tuple[float, float, bytes]:
            reader, writer = await asyncio.open_connection("127.0.0.1", served.port)
            async with await BusMaster.open(served.url) as m:
                temp, hum = await m.pv("TA"), await m.pv("HB")
            sniffed = await reader.read(4096)  # a second host hears the whole exchange
            writer.close()
            return temp, hum, sniffed

        temp, hum, sniffed = asyncio.run(talk())
        assert temp == 19.88  # 0.0625 °C steps: 19.875
        assert hum == 40.0
        assert sniffed.startswith(b":TA,PC,PV|")
        assert served.terminate() == 0


def test_serial_port_option_with_a_real_tty(tmp_path: Path) -> None:
    master, slave = os.openpty()  # the test holds the far end of a "serial cable"
    try:
        device = os.ttyname(slave)
        with ServedBus(tmp_path / "state", "--serial", device, "--speed", "5") as served:
            os.write(master, encode_frame("T1", "PC", "HELLO"))
            received = b""
            expected = encode_frame("PC", "T1", "RHELLO.HCTMPS1-temp server (DS18B20)")
            while not received.endswith(b"\n"):
                ready, _, _ = select.select([master], [], [], 10)
                assert ready, f"no reply on the serial port, got {received!r}"
                received += os.read(master, 4096)
            assert received == expected
            assert served.terminate() == 0
    finally:
        os.close(master)
        os.close(slave)
