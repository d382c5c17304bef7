"""A client of the control API of ``sondalog serve --control`` (issue 23, docs/control.md).

:class:`ControlClient` is blocking (``http.client``, one kept-alive connection, reopened when
the server closed it), so any test suite, threaded or not, calls it directly::

    api = ControlClient("http://127.0.0.1:8070")
    api.pause()
    api.fault("logger", "disconnected", input="analog:16", duration=7200)
    api.step(6 * 3600)
    api.snapshot("logger", "clean"); ...; api.restore("logger", "clean")

Every method answers the API's JSON; a refusal raises :class:`ControlError` with the HTTP
status, the message and the field it names. ``sondalog.testing``'s handles are built on it.
"""

from __future__ import annotations

import http.client
import json
from typing import Any
from urllib.parse import quote, urlsplit


class ControlError(RuntimeError):
    """The control API refused a request: ``status`` (400, 404, 409, ...), ``field``."""

    def __init__(self, status: int, message: str, field: str | None = None) -> None:
        super().__init__(f"{message} (HTTP {status})")
        self.status = status
        self.message = message
        self.field = field


class ControlClient:
    """The control API at ``url`` (``http://HOST:PORT``); ``token``: its bearer token."""

    def __init__(self, url: str, token: str | None = None, timeout: float = 60.0) -> None:
        parts = urlsplit(url)
        if parts.scheme != "http" or parts.hostname is None or parts.port is None:
            raise ValueError(f"a control API URL is http://HOST:PORT, not {url!r}")
        self.url = url.rstrip("/")
        self._host, self._port, self.timeout = parts.hostname, parts.port, timeout
        self._headers = {"Content-Type": "application/json"}
        if token is not None:
            self._headers["Authorization"] = f"Bearer {token}"
        self._conn: http.client.HTTPConnection | None = None

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self) -> ControlClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def request(self, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
        """One request; the answer's JSON. Raises :class:`ControlError` for a refusal."""
        data = None if body is None else json.dumps(body).encode()
        for attempt in (1, 2):  # a kept-alive connection the server closed: once more
            if self._conn is None:
                self._conn = http.client.HTTPConnection(self._host, self._port, self.timeout)
            try:
                self._conn.request(method, path, data, self._headers)
                response = self._conn.getresponse()
                payload = response.read()
                break
            except (ConnectionError, http.client.HTTPException):
                self.close()
                if attempt == 2:
                    raise
        answer = json.loads(payload) if payload else None
        if response.status >= 400:
            error = answer if isinstance(answer, dict) else {}
            raise ControlError(
                response.status, str(error.get("error", payload[:200])), error.get("field")
            )
        return answer

    def _device(self, device: str, action: str, body: dict[str, Any]) -> Any:
        return self.request("POST", f"/devices/{quote(device, safe='')}/{action}", body)

    # -- what there is -----------------------------------------------------------------------
    def devices(self) -> list[dict[str, Any]]:
        answer: list[dict[str, Any]] = self.request("GET", "/devices")
        return answer

    def device(self, name: str) -> dict[str, Any]:
        answer: dict[str, Any] = self.request("GET", f"/devices/{quote(name, safe='')}")
        return answer

    # -- devices -----------------------------------------------------------------------------
    def set(
        self,
        device: str,
        input: str,
        value: float | None = None,
        *,
        signal: dict[str, Any] | None = None,
        rate: float | None = None,
    ) -> Any:
        """An input's ``value`` (a constant), ``signal`` model or pulse ``rate``."""
        given = {"value": value, "signal": signal, "rate": rate}
        return self._device(
            device, "set", {"input": input, **{k: v for k, v in given.items() if v is not None}}
        )

    def fault(self, device: str, kind: str, **params: Any) -> Any:
        """Fault ``kind`` (``input=``, ``duration=`` and the kind's keys: docs/control.md)."""
        return self._device(device, "fault", {"kind": kind, **params})

    def clear(self, device: str, kind: str | None = None, input: str | None = None) -> Any:
        """End the device's faults (all; those of ``kind``; those of ``input``)."""
        body = {k: v for k, v in (("kind", kind), ("input", input)) if v is not None}
        return self._device(device, "clear", body)

    def restart(self, device: str) -> Any:
        return self._device(device, "restart", {})

    def snapshot(self, device: str, name: str = "default") -> Any:
        return self._device(device, "snapshot", {"name": name})

    def restore(self, device: str, name: str = "default") -> Any:
        return self._device(device, "restore", {"name": name})

    # -- time --------------------------------------------------------------------------------
    def time(self) -> dict[str, Any]:
        answer: dict[str, Any] = self.request("GET", "/time")
        return answer

    def pause(self) -> Any:
        return self.request("POST", "/time/pause", {})

    def resume(self) -> Any:
        return self.request("POST", "/time/resume", {})

    def speed(self, factor: float) -> Any:
        return self.request("POST", "/time/speed", {"factor": factor})

    def step(self, seconds: float) -> Any:
        """Move the site's clock ``seconds`` forward; returns once every sample due is taken."""
        return self.request("POST", "/time/step", {"seconds": seconds})
