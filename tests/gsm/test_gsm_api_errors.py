"""Malformed bodies on the served GSM network's HTTP API (issue 20, docs/gsm.md "The HTTP
API"): deeply nested JSON, lone surrogates, oversize bodies, wrong types and missing fields get
a 4xx with a JSON ``{"error", "field"}``, never a 500, and change nothing. One real
``sondalog serve`` per module, spoken to over real HTTP (urllib and raw sockets)."""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from gsm_served import MODEM, PHONE, PHONE2, Served, serve, site_file
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sondalog.app import gsm_api
from sondalog.client.phone import MAX_BODY as CLIENT_MAX_BODY
from sondalog.client.phone import PhoneApi, PhoneApiError

#: The API's limits (sondalog.app.gsm_api.MAX_BODY, MAX_DEPTH), as documented.
MAX_BODY = 64 * 1024
MAX_DEPTH = 32
FIELDS = ("from", "to", "text", "kind", "number", "covered")
BODY_ENDPOINTS = ("/sms", "/call", "/coverage")


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    tmp = tmp_path_factory.mktemp("gsm-api")
    site, _ = site_file(tmp)
    served = serve(site, tmp / "state")
    try:
        yield served
    finally:
        if served.proc.poll() is None:
            served.stop()


def raw_http(served: Served, head: bytes, body: bytes = b"") -> tuple[int, bytes, Any]:
    """Send ``head`` (request line and headers, no blank line) and ``body`` on a fresh
    connection; read until the server closes it. Returns status, headers, parsed JSON body."""
    with socket.create_connection(("127.0.0.1", served.port("gsm API")), timeout=10) as sock:
        sock.sendall(head + b"\r\n\r\n" + body)
        answer = b""
        while chunk := sock.recv(65536):
            answer += chunk
    headers, _, content = answer.partition(b"\r\n\r\n")
    return int(headers.split()[1]), headers.lower(), json.loads(content)


def assert_error(answer: tuple[int, Any], status: int, field: str | None) -> str:
    assert answer[0] == status, answer
    body = answer[1]
    assert isinstance(body, dict) and body["field"] == field, body
    assert isinstance(body["error"], str) and body["error"]
    return body["error"]


def inboxes(served: Served) -> list[Any]:
    """What every subscriber received and what waits for it."""
    out = []
    for number in (PHONE, PHONE2, MODEM):
        for query in ("", "&queued=1"):
            status, listed = served.request("GET", f"/sms?to={number.replace('+', '%2B')}{query}")
            assert status == 200
            out.append(listed)
    return out


def test_deeply_nested_json_gets_400_on_every_body_endpoint(world: Served) -> None:
    deep = b"[" * 30000 + b"]" * 30000  # within the size limit, beyond the parser's recursion
    deep_object = b'{"a":' * 10000 + b"1" + b"}" * 10000
    for path in BODY_ENDPOINTS:
        for body in (deep, deep_object):
            message = assert_error(world.request("POST", path, body), 400, None)
            assert f"deeper than {MAX_DEPTH}" in message
        # nested deeper than MAX_DEPTH inside a field the endpoint reads
        nested: Any = "x"
        for _ in range(MAX_DEPTH):
            nested = [nested]
        body = {"from": PHONE, "to": MODEM, "text": nested, "number": nested, "covered": True}
        assert_error(world.request("POST", path, body), 400, None)
    assert world.request("GET", "/health")[0] == 200


def test_a_lone_surrogate_is_refused_naming_the_field_and_nothing_is_sent(world: Served) -> None:
    before = inboxes(world)
    for to in (PHONE2, MODEM):
        for text in ("\ud800", "ok \udfff then"):
            body = {"from": PHONE, "to": to, "text": text}  # json.dumps writes "\ud800"
            message = assert_error(world.request("POST", "/sms", body), 400, "text")
            assert "surrogate" in message
    # the surrogate's UTF-8-like bytes are not UTF-8 at all
    raw = (
        b'{"from": "'
        + PHONE.encode()
        + b'", "to": "'
        + PHONE2.encode()
        + b'", "text": "\xed\xa0\x80"}'
    )
    assert_error(world.request("POST", "/sms", raw), 400, None)
    assert inboxes(world) == before
    # in the other string fields of every endpoint too
    assert_error(
        world.request("POST", "/sms", {"from": PHONE, "to": "+420\udc00", "text": "x"}), 400, "to"
    )
    assert_error(world.request("POST", "/call", {"from": "\ud83d", "to": MODEM}), 400, "from")
    assert_error(
        world.request("POST", "/coverage", {"number": "\udfff", "covered": False}), 400, "number"
    )
    assert inboxes(world) == before
    assert all(s["covered"] for s in world.request("GET", "/subscribers")[1])


def test_an_oversize_body_gets_413_and_is_not_read(world: Served) -> None:
    host = b"Host: 127.0.0.1"
    # refused by its Content-Length alone: the server answers before any byte of the body
    for path in BODY_ENDPOINTS:
        head = b"POST " + path.encode() + b" HTTP/1.1\r\n" + host + b"\r\nContent-Length: 1000000"
        status, headers, body = raw_http(world, head)
        assert status == 413 and body["field"] is None and str(MAX_BODY) in body["error"]
        assert b"connection: close" in headers and b"application/json" in headers
    # chunked: refused once one byte more than the limit arrived (the last chunk never comes)
    head = b"POST /sms HTTP/1.1\r\n" + host + b"\r\nTransfer-Encoding: chunked"
    chunk = b"%x\r\n" % (MAX_BODY + 1) + b" " * (MAX_BODY + 1) + b"\r\n"
    status, _, body = raw_http(world, head, chunk)
    assert status == 413 and body["field"] is None
    # a whole body one byte over the limit, and one exactly at it (JSON padded with spaces)
    valid = json.dumps({"from": PHONE, "to": PHONE2, "text": "at the limit"}).encode()
    over = valid + b" " * (MAX_BODY + 1 - len(valid))
    assert_error(world.request("POST", "/sms", over), 413, None)
    status, sent = world.request("POST", "/sms", over[:MAX_BODY])
    assert status == 201 and sent["ids"]
    # and the GET endpoints, which read no body, refuse one too
    assert_error(world.request("GET", "/health", b"x" * (MAX_BODY + 1)), 413, None)


def test_wrong_types_missing_fields_and_unknown_paths_answer_json(world: Served) -> None:
    before = inboxes(world)
    cases: list[tuple[str, Any, int, str | None]] = [
        ("/sms", b"not json", 400, None),
        ("/sms", b"NaN", 400, None),
        ("/sms", b'{"from": 1e999999}', 400, "from"),
        ("/sms", b"1" * 5000, 400, None),  # an int longer than Python parses
        ("/sms", [PHONE, MODEM, "x"], 400, None),
        ("/sms", {"from": PHONE, "to": MODEM}, 400, "text"),
        ("/sms", {"to": MODEM, "text": "x"}, 400, "from"),
        ("/sms", {"from": PHONE, "to": MODEM, "text": ["x"]}, 400, "text"),
        ("/sms", {"from": PHONE, "to": {"n": 1}, "text": "x"}, 400, "to"),
        ("/sms", {"from": PHONE, "to": MODEM, "text": "x" * 4001}, 400, "text"),
        ("/sms", {"from": MODEM, "to": PHONE, "text": "x"}, 404, "from"),
        ("/sms", {"from": PHONE, "to": "+4209", "text": "x"}, 404, "to"),
        ("/call", {"from": PHONE, "to": MODEM, "kind": ["voice"]}, 400, "kind"),
        ("/call", {"from": PHONE, "to": MODEM, "kind": "fax"}, 400, "kind"),
        ("/call", {"from": PHONE}, 400, "to"),
        ("/coverage", {"covered": False}, 400, "number"),  # not: the whole network off
        ("/coverage", {"number": MODEM}, 400, "covered"),
        ("/coverage", {"number": MODEM, "covered": 0}, 400, "covered"),
        ("/coverage", {"number": 420, "covered": False}, 400, "number"),
        ("/coverage", {"number": "+٤٢٠", "covered": False}, 400, "number"),
    ]
    for path, body, status, field in cases:
        assert_error(world.request("POST", path, body), status, field)
    assert inboxes(world) == before
    assert all(s["covered"] for s in world.request("GET", "/subscribers")[1])
    assert_error(world.request("GET", "/nowhere"), 404, None)
    assert_error(world.request("POST", "/health", {}), 405, None)
    assert_error(world.request("GET", "/calls/" + "9" * 5000), 404, None)
    assert_error(world.request("DELETE", "/calls/%ED%A0%80"), 404, None)


def test_the_phone_client_reports_the_refusal(world: Served) -> None:
    assert gsm_api.MAX_BODY == MAX_BODY == CLIENT_MAX_BODY
    assert gsm_api.MAX_DEPTH == MAX_DEPTH
    phone = PhoneApi(world.api)
    with pytest.raises(PhoneApiError) as refused:
        phone.sms(PHONE, PHONE2, "bad \udc80 byte")  # what a shell's invalid UTF-8 becomes
    assert refused.value.status == 400 and "body.text: has a lone surrogate U+DC80" in str(
        refused.value
    )
    with pytest.raises(PhoneApiError) as refused:  # refused before sending: not "cannot reach"
        phone.sms(PHONE, PHONE2, "x" * 1_000_000)
    assert refused.value.status == 413 and str(MAX_BODY) in refused.value.message
    assert phone.sms(PHONE, PHONE2, "fine")["ids"]


def test_docs_state_the_limits_and_the_error_format() -> None:
    doc = (Path(__file__).resolve().parents[2] / "docs" / "gsm.md").read_text(encoding="utf-8")
    api = doc.split("## The HTTP API", 1)[1].split("\n## ", 1)[0]
    assert f"64 KiB ({MAX_BODY} bytes)" in api and f"deeper than {MAX_DEPTH} levels" in api
    assert '{"error": "what is wrong", "field": "text"}' in api


# -- random JSON to every endpoint ---------------------------------------------------------

STRINGS = st.one_of(
    st.text(max_size=12),
    st.sampled_from([PHONE, PHONE2, MODEM, "00420700000001", "+4209", "", "voice", "data"]),
    st.sampled_from(["\ud800", "a\udfffb", "\U0001f600", "+٤٢٠", "\x00", "\x1a\r\n"]),
)
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), STRINGS)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(st.one_of(st.sampled_from(FIELDS), st.text(max_size=4)), inner, max_size=4),
    ),
    max_leaves=12,
)
#: A request each endpoint takes; changed at random, most stay valid or nearly so.
VALID = {
    "/sms": {"from": PHONE, "to": PHONE2, "text": "hi"},
    "/call": {"from": PHONE, "to": MODEM, "kind": "voice"},
    "/coverage": {"number": MODEM, "covered": True},
}


def near(valid: dict[str, Any]) -> st.SearchStrategy[Any]:
    def change(dropped: list[str], changed: dict[str, Any]) -> dict[str, Any]:
        return {k: v for k, v in valid.items() if k not in dropped} | changed

    keys = st.sampled_from(FIELDS)
    return st.builds(change, st.lists(keys, max_size=2), st.dictionaries(keys, VALUES, max_size=2))


def bodies(path: str) -> st.SearchStrategy[bytes]:
    """JSON objects with the keys the endpoints know, any JSON value, bytes that are not JSON;
    strings with lone surrogates as JSON escapes and as (invalid) UTF-8."""
    documents = st.one_of(
        near(VALID.get(path, {})), st.dictionaries(st.sampled_from(FIELDS), VALUES), VALUES
    )
    return st.one_of(
        documents.map(lambda v: json.dumps(v).encode()),
        documents.map(lambda v: json.dumps(v, ensure_ascii=False).encode("utf-8", "surrogatepass")),
        st.binary(max_size=40),
    )


ENDPOINTS = [
    ("POST", "/sms"),
    ("POST", "/call"),
    ("POST", "/coverage"),
    ("GET", "/health"),
    ("GET", "/subscribers"),
    ("GET", "/sms?to=%2B420700000001"),
    ("GET", "/calls"),
    ("GET", "/calls/1"),
    ("DELETE", "/calls/1"),
    ("POST", "/health"),
]


@pytest.mark.parametrize(("method", "path"), ENDPOINTS)
def test_random_json_never_gets_5xx(world: Served, method: str, path: str) -> None:
    statuses: set[int] = set()

    @settings(
        max_examples=40,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(bodies(path))
    @example(json.dumps(VALID.get(path, {})).encode())
    @example(b"[" * 2000 + b"]" * 2000)
    def post(body: bytes) -> None:
        status, answer = world.request(method, path, body)  # raises unless the answer is JSON
        statuses.add(status)
        assert 200 <= status < 500, (body, status, answer)
        if status >= 400:
            assert isinstance(answer["error"], str) and answer["error"]
            unknown = "unknown table or key" in answer["error"]  # named, whatever it is
            assert answer["field"] is None or answer["field"] in FIELDS or unknown

    post()
    if path in VALID:  # valid requests were applied, the others refused
        assert 400 in statuses and statuses & {200, 201}, statuses
    # the server keeps working
    assert world.proc.poll() is None
    status, sent = world.request("POST", "/sms", VALID["/sms"])
    assert status == 201 and sent["ids"]
    assert world.request("POST", "/coverage", {"number": None, "covered": True})[0] == 200
    assert world.request("GET", "/health") == (200, {"ok": True, "subscribers": 3})
