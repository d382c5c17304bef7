"""A fleet of 50 virtual loggers in one station file, one of them unreachable (issue 22):
one line per logger, a summary, and a failure on one never stops the others."""

from __future__ import annotations

import asyncio
import contextlib
import socket
from pathlib import Path

from station_helpers import ask, explain_text, served

from sondalog.client.station_fleet import read_file, run_fleet, summary

COUNT = 50


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_fifty_loggers_one_unreachable(tmp_path: Path) -> None:
    async def run() -> None:
        async with contextlib.AsyncExitStack() as stack:
            loggers = [
                await stack.enter_async_context(
                    served(tmp_path / f"s{n}", "1.16" if n % 2 else "2.10", f"F{n:02d}")
                )
                for n in range(1, COUNT)
            ]
            dead = f"tcp://127.0.0.1:{_closed_port()}"
            entries = [
                f'[[logger]]\nurl = "{lg.url}"\nserial_number = "F{n:02d}"\n'
                f'[logger.identity]\nname = "Stanice {n}"\n'
                for n, lg in enumerate(loggers, start=1)
            ]
            entries.insert(17, f'[[logger]]\nurl = "{dead}"\n')
            path = tmp_path / "fleet.toml"
            path.write_text(
                '[channel]\nmax_number = 2\n[channel.2]\nsampling_period = "001000"\n'
                + "".join(entries)
            )
            targets = read_file(path)
            lines: list[str] = []
            results = await run_fleet(targets, explain_text, 8, lambda r: lines.append(r.line()))
            assert len(lines) == COUNT
            assert summary(results) == f"{COUNT} loggers: {COUNT - 1} changed, 1 failed"
            failed = [r for r in results if r.state == "failed"]
            assert [r.url for r in failed] == [dead] and "cannot reach" in failed[0].detail
            assert all(r.detail == "3 writes verified" for r in results if r.state == "changed")
            assert await ask(loggers[6].url, ["read i name"]) == ["OK"]
            again = await run_fleet(targets, explain_text, 8)  # idempotent
            assert sorted(r.state for r in again) == ["failed"] + ["unchanged"] * (COUNT - 1)
            assert summary(await run_fleet(targets, None, 8)) == (
                f"{COUNT} loggers: {COUNT - 1} unchanged, 1 failed"
            )

    asyncio.run(run())
