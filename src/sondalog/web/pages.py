"""The dashboard's HTML pages, rendered on the server (readable without JavaScript).

Only the plot needs scripts (``static/plot.js`` with the vendored uPlot); the overview and
the log are plain HTML with native, labelled controls. The markup lives in Jinja2 templates
(``web/templates/``, starlette's own templating) with autoescape on: every value from the
store (logger, channel and source names, units, log text) is escaped unless it is
``Markup``. The functions here only prepare values as plain text.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any
from urllib.parse import quote, urlencode

from jinja2 import Environment, PackageLoader, StrictUndefined

#: What marks a time of the logger's own clock (no zone: the logger's clock is its own).
LOGGER_CLOCK = "logger clock"


def _num(value: object, digits: int = 2, decimals: int | None = None) -> str:
    """A number as the channel's format writes it (``decimals``), else up to ``digits``."""
    if value is None:
        return "—"
    if isinstance(value, int | float) and decimals is not None:
        return f"{value:.{decimals}f}"
    if isinstance(value, float):
        return f"{value:.{digits}f}".rstrip("0").rstrip(".") if value % 1 else f"{value:.0f}"
    return str(value)


def host_clock(stamp: object) -> str:
    """A time of this computer's clock (``last_contact``, events: ISO with the host's
    offset) as ``YYYY-MM-DD HH:MM:SS UTC+01:00`` (``UTC`` when the offset is 0); empty
    when it is no ISO time (the page then shows it as it is)."""
    try:
        when = datetime.fromisoformat(str(stamp))
    except ValueError:
        return ""
    offset = when.utcoffset()
    if offset is None:
        zone = "(zone unknown)"
    elif not offset:
        zone = "UTC"
    else:
        zone = "UTC" + when.strftime("%z")[:3] + ":" + when.strftime("%z")[3:]
    return f"{when:%Y-%m-%d %H:%M:%S} {zone}"


def clock_offset(seconds: float) -> str:
    """The logger's clock against this computer's at the last contact, in words."""
    if round(seconds) == 0:
        return "on time with this computer"
    way = "ahead of" if seconds > 0 else "behind"
    size = f"{abs(seconds):.0f} s"
    if abs(seconds) >= 120:
        size += f" ({abs(seconds) / 60:.0f} min)" if abs(seconds) < 7200 else ""
        size += f" ({abs(seconds) / 3600:.1f} h)" if abs(seconds) >= 7200 else ""
    return f"{size} {way} this computer"


def logger_url(logger: str) -> str:
    return "/loggers/" + quote(logger, safe="")


def record_fill(status: str) -> str:
    """``record status`` (``chars,fraction,STATE``, §6.6.5) in words."""
    parts = status.split(",")
    try:
        chars, fraction, state = int(parts[0]), float(parts[1]), parts[2]
    except (IndexError, ValueError):
        return status
    return f"{fraction * 100:.0f} % full ({chars:,} characters), {state}"


def _finalize(value: object) -> object:
    """``None`` shows as nothing (an unnamed channel, a source without URL)."""
    return "" if value is None else value


#: The pages' templates, escaped on output (the package's own files, so an installed
#: wheel finds them: ``[tool.setuptools.package-data]``).
ENV = Environment(
    loader=PackageLoader("sondalog.web", "templates"),
    autoescape=True,
    undefined=StrictUndefined,
    keep_trailing_newline=True,
    finalize=_finalize,
)
ENV.filters.update(
    num=_num,
    host_clock=host_clock,
    clock_offset=clock_offset,
    logger_url=logger_url,
    record_fill=record_fill,
)
ENV.globals.update(clock=LOGGER_CLOCK, current="", alarm_count=None, alarms_unavailable=None)


def render(name: str, **context: Any) -> str:
    return ENV.get_template(name).render(**context)


def overview(
    data: dict[str, Any],
    *,
    refresh_s: float = 10.0,
    alarms: list[dict[str, Any]] | None = None,
    unavailable: str | None = None,
) -> str:
    """The overview; ``alarms``: the active ones (:func:`sondalog.web.alarms.active`);
    ``unavailable``: why the alarm store could not be read (the page says so instead of
    "No active alarms")."""
    alarms = alarms or []
    return render(
        "overview.html",
        title="Overview",
        current="/",
        refresh_s=refresh_s,
        loggers=data["loggers"],
        unbound_sources=data["unbound_sources"],
        alarms=alarms,
        alarm_count=len(alarms),
        alarms_unavailable=unavailable,
    )


def plot(
    logger: str,
    channels: list[dict[str, Any]],
    *,
    alarms: list[dict[str, Any]] | None = None,
    alarm_count: int | None = None,
    refresh_s: float = 10.0,
    config_changes: list[dict[str, Any]] | None = None,
    unavailable: str | None = None,
) -> str:
    """A logger's page: its plot, its active ``alarms`` (``unavailable``: as
    :func:`overview`) and its ``config_changes`` (rows of
    :func:`sondalog.web.config_log.changes`)."""
    return render(
        "plot.html",
        title=logger,
        logger=logger,
        channels=channels,
        alarms=alarms or [],
        alarm_count=alarm_count,
        refresh_s=refresh_s,
        config_changes=config_changes or [],
        alarms_unavailable=unavailable,
    )


def log(
    events: list[dict[str, Any]],
    *,
    source: str | None,
    limit: int,
    alarm_history: list[dict[str, Any]] | None = None,
    alarm_count: int | None = None,
    refresh_s: float = 10.0,
    unavailable: str | None = None,
) -> str:
    params = {"source": source} if source else {}
    older = None
    if len(events) == limit:
        older = "/log?" + urlencode({**params, "before": events[-1]["id"]})
    return render(
        "log.html",
        title="Log",
        current="/log",
        events=events,
        alarm_history=alarm_history or [],
        alarm_count=alarm_count,
        refresh_s=refresh_s,
        alarms_unavailable=unavailable,
        source=source,
        newest="/log?" + urlencode(params),
        older=older,
    )


def error(status: int, detail: object) -> str:
    """The page of an HTTP error (its status and what went wrong)."""
    return render("error.html", title=str(status), detail=detail)
