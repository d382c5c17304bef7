"""One line of plain text per transition: what every destination says (e-mail subject, SMS,
the log, the dashboard's history)."""

from __future__ import annotations

from datetime import UTC, datetime

from .rules import Rule


def when(time: float) -> str:
    """``2024-03-01T11:00:00Z``."""
    return datetime.fromtimestamp(time, UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:g}"


def raised_text(rule: Rule, subject: str, value: float | None, extra: str = "") -> str:
    what = f"{rule.name}: {subject}"
    match rule.kind:
        case "threshold" | "health":
            measure = f" {rule.measure}" if rule.kind == "health" else ""
            n = f" for {rule.count} readings" if rule.count > 1 else ""
            return f"{what}{measure} {_num(value)} {rule.direction} {rule.limit:g}{n}"
        case "stuck":
            return f"{what} stuck at {_num(value)} for {rule.count} readings"
        case "step":
            return f"{what} jumped {extra} to {_num(value)} (more than {rule.step:g})"
        case "no_contact":
            return f"{what} not contacted for {_num(value)} s"
        case "collector":
            match rule.watch:
                case "sink":
                    return f"{what} sink down for {_num(value)} s"
                case "buffer":
                    return f"{what} {_num(value)} batches buffered (more than {rule.limit:g})"
            return f"{what} {_num(value)} failed contacts in a row{extra}"
    return what


def cleared_text(rule: Rule, subject: str, value: float | None) -> str:
    what = f"{rule.name}: {subject}"
    match rule.kind:
        case "threshold" | "health" | "buffer":
            side = "at or below" if rule.direction == "above" else "at or above"
            return f"{what} back {side} {rule.clear:g}: {_num(value)}"
        case "no_contact":
            return f"{what} contacted again"
        case "collector":
            return f"{what} back to normal ({_num(value)})"
    return f"{what} back to normal: {_num(value)}"
