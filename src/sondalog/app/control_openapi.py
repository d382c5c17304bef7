"""The OpenAPI 3.1 description of the control API (issue 23), served at ``/openapi.json``.

Written from the vocabulary it describes (:mod:`sondalog.app.control_actions`: the fault
kinds, the input pattern, the limits), so the description and the checks cannot drift apart;
``tests/control/test_openapi.py`` checks every route of the app is in it.
"""

from __future__ import annotations

from typing import Any

from sondalog import __version__
from sondalog.app.control_actions import FAULTS, INPUT_PATTERN, MAX_SECONDS, MAX_SPEED, NAME_PATTERN
from sondalog.backends.sim.signals import MODELS

_ERROR = {
    "type": "object",
    "required": ["error", "field"],
    "properties": {
        "error": {"type": "string"},
        "field": {"type": ["string", "null"], "description": "the body's field at fault"},
    },
}
_INPUT = {"type": "string", "pattern": f"^({INPUT_PATTERN})$", "example": "analog:16"}
_SECONDS = {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_SECONDS}
_DURATION = r"^(\d+(\.\d+)?|(\d+(\.\d+)?d)?(\d+(\.\d+)?h)?(\d+(\.\d+)?m)?(\d+(\.\d+)?s)?)$"


def _schema(
    properties: dict[str, Any], required: list[str] | None = None, **more: Any
) -> dict[str, Any]:
    schema: dict[str, Any] = {
        "type": "object",
        "additionalProperties": False,
        "properties": properties,
    }
    if required:
        schema["required"] = required
    return {**schema, **more}


_SCHEMAS: dict[str, Any] = {
    "Error": _ERROR,
    "Set": _schema(
        {
            "input": _INPUT,
            "value": {"type": "number", "description": "a constant: volts, °C, dBm, credit"},
            "signal": {
                "type": "object",
                "description": "a signal model (docs/simulation.md), times after now",
                "properties": {"model": {"enum": list(MODELS)}},
                "required": ["model"],
            },
            "rate": {"type": "number", "minimum": 0, "maximum": 1e6, "description": "pulses/s"},
        },
        ["input"],
        description="exactly one of value, signal (not for pulses:...) or rate (pulses:... only)",
    ),
    "Fault": _schema(
        {
            "kind": {"enum": list(FAULTS)},
            "input": {
                **_INPUT,
                "description": "for disconnected, stuck (also a bus's module:ID), "
                "power_on_reset, bad_crc",
            },
            "duration": {
                "oneOf": [_SECONDS, {"type": "string", "pattern": _DURATION}],
                "description": "clock seconds (or 90s, 15m, 2h30m, 1d) until it ends by itself",
            },
            "volts": {"type": "number", "minimum": 0, "maximum": 40, "description": "brownout"},
            "seconds": {"type": "number", "description": "clock_jump: seconds, + or -, not 0"},
            "rate": {
                "type": "number",
                "exclusiveMinimum": 0,
                "maximum": 1,
                "description": "noise: per byte",
            },
            "seed": {"type": "integer", "minimum": 0, "description": "noise"},
            "direction": {"enum": ["out", "in", "both"], "description": "noise (default out)"},
            "mode": {"enum": ["mixed", "flip", "drop", "duplicate"], "description": "noise"},
            "baud": {"type": "integer", "minimum": 10, "maximum": 230400, "description": "slow"},
            "latency": {"type": "number", "minimum": 0, "maximum": 3600, "description": "slow"},
            "number": {"type": "string", "description": "no_coverage (gsm): one subscriber"},
            "code": {
                "type": "integer",
                "minimum": 400,
                "maximum": 599,
                "default": 451,
                "description": "smtp_refusing (mail)",
            },
        },
        ["kind"],
    ),
    "Clear": _schema({"kind": {"enum": list(FAULTS)}, "input": _INPUT}),
    "Named": _schema(
        {"name": {"type": "string", "pattern": f"^{NAME_PATTERN}$", "default": "default"}}
    ),
    "Speed": _schema(
        {"factor": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_SPEED}}, ["factor"]
    ),
    "Step": _schema(
        {"seconds": {"type": "number", "minimum": 0, "maximum": MAX_SECONDS}}, ["seconds"]
    ),
    "Empty": _schema({}),
}

_BODIES = {
    "set": "Set",
    "fault": "Fault",
    "clear": "Clear",
    "restart": "Empty",
    "snapshot": "Named",
    "restore": "Named",
    "pause": "Empty",
    "resume": "Empty",
    "speed": "Speed",
    "step": "Step",
}


def _errors(*codes: int) -> dict[str, Any]:
    ref = {"content": {"application/json": {"schema": {"$ref": "#/components/schemas/Error"}}}}
    reasons = {
        400: "a field is missing, unknown, of the wrong type or out of range",
        404: "no such device, input, snapshot or action",
        409: "the device's state refuses it (fault active, no power, real hardware)",
        413: "the body is too large",
    }
    return {str(code): {"description": reasons[code], **ref} for code in codes}


def _ok(description: str) -> dict[str, Any]:
    return {
        "200": {
            "description": description,
            "content": {"application/json": {"schema": {"type": "object"}}},
        }
    }


def _post(action: str, summary: str, device: bool) -> dict[str, Any]:
    operation: dict[str, Any] = {
        "summary": summary,
        "operationId": f"{'device' if device else 'time'}_{action}",
        "requestBody": {
            "required": False,
            "content": {
                "application/json": {"schema": {"$ref": f"#/components/schemas/{_BODIES[action]}"}}
            },
        },
        "responses": {**_ok("applied"), **_errors(400, 404, 409, 413)},
    }
    if device:
        operation["parameters"] = [
            {"name": "name", "in": "path", "required": True, "schema": {"type": "string"},
             "description": "logger, loggers.SERIAL, bus, gsm, mail"},
        ]  # fmt: skip
    return {"post": operation}


_DEVICE = {
    "set": "set an input's value, signal model or pulse rate",
    "fault": "inject a fault",
    "clear": "end faults (all, of a kind, of an input)",
    "restart": "restart the logger from its saved state",
    "snapshot": "keep the logger's whole state under a name",
    "restore": "put back a kept state (the logger restarts with it)",
}
_TIME = {
    "pause": "stop the site's clock",
    "resume": "let the site's clock run again",
    "speed": "run the clock this many times real time",
    "step": "move the clock forward, running all that falls due",
}


def openapi() -> dict[str, Any]:
    """The description (a fresh dict)."""
    name = [{"name": "name", "in": "path", "required": True, "schema": {"type": "string"}}]
    paths: dict[str, Any] = {
        "/health": {"get": {"summary": "alive", "operationId": "health", "responses": _ok("ok")}},
        "/openapi.json": {
            "get": {
                "summary": "this description",
                "operationId": "openapi",
                "responses": _ok("the description"),
            }
        },
        "/devices": {
            "get": {
                "summary": "every device",
                "operationId": "devices",
                "responses": _ok("the devices"),
            }
        },
        "/devices/{name}": {
            "get": {
                "summary": "one device: inputs now, module time, record rows, faults, snapshots",
                "operationId": "device",
                "parameters": name,
                "responses": {**_ok("the device"), **_errors(404)},
            }
        },
        "/time": {
            "get": {
                "summary": "the site's clock",
                "operationId": "time",
                "responses": _ok("the clock"),
            }
        },
    }
    for action, summary in _DEVICE.items():
        paths[f"/devices/{{name}}/{action}"] = _post(action, summary, True)
    for action, summary in _TIME.items():
        paths[f"/time/{action}"] = _post(action, summary, False)
    return {
        "openapi": "3.1.0",
        "info": {
            "title": "sondalog control API",
            "version": __version__,
            "description": "Inputs, faults, time and state of the devices of "
            "`sondalog serve --control` (docs/control.md).",
        },
        "paths": paths,
        "components": {
            "schemas": _SCHEMAS,
            "securitySchemes": {"token": {"type": "http", "scheme": "bearer"}},
        },
    }
