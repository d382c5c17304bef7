"""Bad requests to the control API: a 4xx with JSON naming the field, nothing applied."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from control_site import http, served

from sondalog.app.gsm_api import MAX_BODY

#: (path, body) -> (status, field at fault)
CASES = [
    ("/devices/nope/fault", {"kind": "cut"}, 404, "device"),
    ("/devices/logger/explode", {}, 404, None),
    ("/devices/logger/fault", {"kind": "melted"}, 400, "kind"),
    ("/devices/logger/fault", {"kind": "disconnected"}, 400, "input"),
    ("/devices/logger/fault", {"kind": "disconnected", "input": "analog:17"}, 404, "input"),
    ("/devices/logger/fault", {"kind": "disconnected", "input": "flux:1"}, 400, "input"),
    ("/devices/logger/fault", {"kind": "power_on_reset", "input": "analog:16"}, 400, "input"),
    ("/devices/logger/fault", {"kind": "noise", "rate": 2}, 400, "rate"),
    ("/devices/logger/fault", {"kind": "noise", "rate": "often"}, 400, "rate"),
    ("/devices/logger/fault", {"kind": "noise", "rate": 0.1, "baud": 300}, 400, "baud"),
    ("/devices/logger/fault", {"kind": "cut", "duration": -1}, 400, "duration"),
    ("/devices/logger/fault", {"kind": "clock_jump", "seconds": 0}, 400, "seconds"),
    ("/devices/logger/fault", {"kind": "brownout"}, 400, "volts"),
    ("/devices/logger/fault", {"kind": "cut", "colour": "red"}, 400, "colour"),
    ("/devices/logger/set", {"input": "analog:16", "value": True}, 400, "value"),
    ("/devices/logger/set", {"input": "analog:16", "value": 1, "rate": 2}, 400, "value"),
    (
        "/devices/logger/set",
        {"input": "analog:16", "signal": {"model": "sine"}},
        400,
        "signal.mean",
    ),
    ("/devices/logger/set", {"input": "pulses:timer", "value": 3}, 400, "value"),
    (
        "/devices/logger/set",
        {"input": "supply", "signal": {"model": "csv", "path": "/etc/passwd"}},
        400,
        "signal.model",
    ),
    (
        "/devices/logger/set",
        {
            "input": "supply",
            "signal": {"model": "random_walk", "start": 1, "step": 1, "interval": 1e-9},
        },
        400,
        "signal.interval",
    ),
    ("/devices/logger/set", {"input": "analog:16", "rate": 3}, 400, "rate"),
    ("/devices/logger/set", {"input": "supply", "value": 1e12}, 400, "value"),
    ("/devices/logger/restore", {"name": "never"}, 404, "name"),
    ("/devices/logger/snapshot", {"name": "../x"}, 400, "name"),
    ("/time/step", {"seconds": -5}, 400, "seconds"),
    ("/time/step", {}, 400, "seconds"),
    ("/time/speed", {"factor": 0}, 400, "factor"),
    ("/time/rewind", {}, 404, None),
]


def test_each_bad_request_names_its_field_and_changes_nothing(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            before = await site.get("/devices/logger")
            clock = await site.get("/time")
            for path, body, status, field in CASES:
                got, answer = await http(site.port, "POST", path, body)
                assert (got, answer["field"]) == (status, field), (path, body, answer)
                assert isinstance(answer["error"], str) and answer["error"]
            assert await site.get("/devices/logger") == before
            assert await site.get("/time") == clock

    asyncio.run(main())


@pytest.mark.parametrize(
    "raw",
    [b"[1, 2]", b"not json", b'{"kind": NaN}', b"\xff\xfe", b"[" * 40 + b"]" * 40, b'"cut"'],
)
def test_a_body_that_is_not_a_json_object_is_refused(tmp_path: Path, raw: bytes) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            status, answer = await http(site.port, "POST", "/devices/logger/fault", raw=raw)
            assert status == 400 and answer["field"] is None, answer
            assert (await site.get("/devices/logger"))["faults"] == []

    asyncio.run(main())


def test_a_body_too_large_is_413_and_deep_nesting_400(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            big = json.dumps({"kind": "cut", "pad": "x" * MAX_BODY}).encode()
            status, answer = await http(site.port, "POST", "/devices/logger/fault", raw=big)
            assert status == 413, answer
            deep = b'{"kind": "cut", "x": ' + b"[" * 50 + b"]" * 50 + b"}"
            status, answer = await http(site.port, "POST", "/devices/logger/fault", raw=deep)
            assert status == 400 and "nests" in answer["error"]

    asyncio.run(main())


def test_a_state_that_refuses_is_409(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await site.post("/devices/logger/fault", {"kind": "power_loss"})
            answer = await site.post("/devices/logger/fault", {"kind": "power_loss"}, 409)
            assert answer["field"] == "kind"
            answer = await site.post("/devices/logger/restart", {}, 409)
            # an unknown snapshot: refused before the faults a restore would end
            answer = await site.post("/devices/logger/restore", {"name": "never"}, 404)
            assert answer["field"] == "name"
            assert not (await site.get("/devices/logger"))["powered"]
            await site.post("/devices/logger/clear", {})
            assert (await site.get("/devices/logger"))["powered"]

    asyncio.run(main())


def test_with_a_token_every_request_needs_it(tmp_path: Path) -> None:
    token = "s3cret-token-of-the-tests"

    async def main() -> None:
        async with served(tmp_path, token=token) as site:
            status, _ = await http(site.port, "GET", "/devices")
            assert status == 401
            bearer = {"Authorization": f"Bearer {token}"}
            status, answer = await http(site.port, "GET", "/devices", headers=bearer)
            assert status == 200 and answer[0]["name"] == "logger"
            wrong = {"Authorization": "Bearer nope-nope-nope-nope"}
            status, _ = await http(site.port, "POST", "/time/step", {"seconds": 5}, headers=wrong)
            assert status == 401

    asyncio.run(main())
