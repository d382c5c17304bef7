"""The dashboard's HTML pages, rendered on the server (readable without JavaScript).

Only the plot needs scripts (``static/plot.js`` with the vendored uPlot); the overview and
the log are plain HTML with native, labelled controls.
"""

from __future__ import annotations

from datetime import datetime
from html import escape
from typing import Any
from urllib.parse import quote, urlencode


def _e(value: object) -> str:
    return "" if value is None else escape(str(value))


def _num(value: object, digits: int = 2, decimals: int | None = None) -> str:
    """A number as the channel's format writes it (``decimals``), else up to ``digits``."""
    if value is None:
        return "—"
    if isinstance(value, int | float) and decimals is not None:
        return f"{value:.{decimals}f}"
    if isinstance(value, float):
        return f"{value:.{digits}f}".rstrip("0").rstrip(".") if value % 1 else f"{value:.0f}"
    return _e(value)


#: What marks a time of the logger's own clock (no zone: the logger's clock is its own).
LOGGER_CLOCK = "logger clock"


def logger_time(stamp: object) -> str:
    """A store time (logger's clock) as every page shows times: ``YYYY-MM-DD HH:MM:SS``."""
    if not stamp:
        return ""
    text = str(stamp)
    return f'<time datetime="{_e(text)}">{_e(text.replace("T", " "))}</time>'


def host_time(stamp: object) -> str:
    """A time of this computer's clock (``last_contact``, events: ISO with the host's
    offset) as ``YYYY-MM-DD HH:MM:SS UTC+01:00`` (``UTC`` when the offset is 0)."""
    if not stamp:
        return ""
    text = str(stamp)
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        return _e(text)
    offset = when.utcoffset()
    if offset is None:
        zone = "(zone unknown)"
    elif not offset:
        zone = "UTC"
    else:
        zone = "UTC" + when.strftime("%z")[:3] + ":" + when.strftime("%z")[3:]
    return f'<time datetime="{_e(text)}">{when:%Y-%m-%d %H:%M:%S} {zone}</time>'


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


def page(title: str, body: str, *, head: str = "", current: str = "", main_attrs: str = "") -> str:
    def nav(href: str, label: str) -> str:
        aria = ' aria-current="page"' if current == href else ""
        return f'<a href="{href}"{aria}>{label}</a>'

    return f"""<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(title)} · sondalog</title>
<link rel="icon" href="data:,">
<link rel="stylesheet" href="/static/app.css">
{head}
</head>
<body>
<a class="skip" href="#main">Skip to content</a>
<header><span class="brand">sondalog</span>
<nav aria-label="Main">{nav("/", "Overview")} {nav("/log", "Log")}</nav></header>
<main id="main"{main_attrs}>
{body}
</main>
</body>
</html>
"""


def record_fill(status: str) -> str:
    """``record status`` (``chars,fraction,STATE``, §6.6.5) in words."""
    parts = status.split(",")
    try:
        chars, fraction, state = int(parts[0]), float(parts[1]), parts[2]
    except (IndexError, ValueError):
        return _e(status)
    return _e(f"{fraction * 100:.0f} % full ({chars:,} characters), {state}")


def _source(s: dict[str, Any]) -> str:
    trouble = (
        f'<p class="alert"><strong>Trouble:</strong> state {_e(s["state"])}'
        + (f", {_e(s['last_error'])}" if s.get("last_error") else "")
        + "</p>"
        if s["trouble"]
        else ""
    )
    return (
        f'<li><span class="src">{_e(s["name"])}</span> <code>{_e(s["url"])}</code> '
        f"({_e(s['kind'])}, {_e(s['state'])}, "
        f"last contact {host_time(s['last_contact']) or 'never'})"
        f"{trouble}</li>"
    )


def overview(data: dict[str, Any], *, refresh_s: float = 10.0) -> str:
    cards: list[str] = []
    for lg in data["loggers"]:
        cls = "card trouble" if lg["trouble"] else "card"
        what = "Module" if lg["module"] else "Logger"
        rows = "".join(
            f'<tr><th scope="row">{c["channel"]}</th><td>{_e(c["name"])}</td>'
            f'<td class="num">{_num(c["value"], 4, c.get("decimals"))}</td>'
            f"<td>{_e(c['unit'])}</td><td>{logger_time(c['time'])}</td></tr>"
            for c in lg["channels"]
        )
        table = (
            '<div class="scroll"><table><caption>Last values</caption><thead><tr>'
            '<th scope="col">Ch</th><th scope="col">Name</th><th scope="col">Value</th>'
            '<th scope="col">Unit</th><th scope="col">Time (logger clock)</th></tr></thead>'
            f"<tbody>{rows}</tbody></table></div>"
            if rows
            else "<p>No readings yet.</p>"
        )
        facts = [
            (f"Last reading ({LOGGER_CLOCK})", logger_time(lg["last_reading"]) or "none"),
            ("Last contact (this computer)", host_time(lg["last_contact"]) or "—"),
        ]
        if lg.get("offset_s") is not None:
            facts.append(("Logger clock", clock_offset(float(lg["offset_s"]))))
        if lg["record_fill"] is not None:
            facts.append(("Record", record_fill(str(lg["record_fill"]))))
        if lg["signal"] is not None:
            facts.append(("GSM signal", _num(lg["signal"])))
        if lg["credit"] is not None:
            facts.append(("Credit", _num(lg["credit"])))
        dl = "".join(f"<div><dt>{k}</dt><dd>{v}</dd></div>" for k, v in facts)
        srcs = "".join(_source(s) for s in lg["sources"])
        status = '<span class="badge">trouble</span>' if lg["trouble"] else ""
        cards.append(
            f'<section class="{cls}" aria-labelledby="h-{_e(lg["logger"])}">'
            f'<h2 id="h-{_e(lg["logger"])}">{what} <a href="{logger_url(lg["logger"])}">'
            f"{_e(lg['logger'])}</a> {status}</h2>"
            f'<dl class="facts">{dl}</dl>{table}'
            + (f'<ul class="sources">{srcs}</ul>' if srcs else "")
            + "</section>"
        )
    unbound = "".join(_source(s) for s in data["unbound_sources"])
    if unbound:
        cards.append(
            '<section class="card"><h2>Sources not yet identified</h2>'
            f'<ul class="sources">{unbound}</ul></section>'
        )
    if not cards:
        cards.append("<p>The store has no loggers yet.</p>")
    body = "<h1>Overview</h1>" + "".join(cards)
    return page(
        "Overview",
        body,
        current="/",
        head='<script type="module" src="/static/overview.js"></script>',
        main_attrs=f' data-refresh="{refresh_s:g}"',
    )


#: The From/To fields: text in the one time format of every page (a ``datetime-local``
#: field would show the browser's locale format instead).
TIME_INPUT = (
    'type="text" inputmode="numeric" autocomplete="off" placeholder="YYYY-MM-DD HH:MM:SS" '
    'pattern="\\d{4}-\\d{2}-\\d{2}([ T]\\d{2}:\\d{2}(:\\d{2})?)?" size="19"'
)


def plot(logger: str, channels: list[dict[str, Any]]) -> str:
    legend = "".join(
        f'<li><input type="checkbox" id="show-{c["channel"]}" data-channel="{c["channel"]}"'
        f' checked> <label for="show-{c["channel"]}">{c["channel"]}: {_e(c["name"])}'
        f"{(' [' + _e(c['unit']) + ']') if c['unit'] else ''}"
        f"{' (events, bars)' if c['kind'] == 'bars' else ''}</label></li>"
        for c in channels
    )
    body = f"""<h1>{_e(logger)}</h1>
<form id="range" class="range" data-logger="{_e(logger)}">
<div><label for="from">From ({LOGGER_CLOCK})</label>
<input id="from" name="from" {TIME_INPUT}></div>
<div><label for="to">To ({LOGGER_CLOCK})</label>
<input id="to" name="to" {TIME_INPUT}></div>
<div class="buttons"><button type="submit">Show</button>
<button type="button" data-span="86400">Last day</button>
<button type="button" data-span="604800">Last week</button>
<button type="button" data-span="2678400">Last month</button>
<button type="button" data-span="31622400">Last year</button></div>
<div class="check"><input id="live" type="checkbox" checked>
<label for="live">Live updates</label></div>
<div><a id="csv" href="#" download>Download CSV of this range</a></div>
</form>
<p id="status" role="status" aria-live="polite">Loading…</p>
<div id="plot" data-state="loading" role="img"
 aria-label="Plot of {_e(logger)}: one series per channel; drag across it to zoom"></div>
<p class="hint">Drag across the plot to show that range; the browser's Back button returns.
Times are the logger's own clock, 24-hour, as YYYY-MM-DD HH:MM:SS.</p>
<fieldset class="legend"><legend>Channels shown</legend><ul>{legend}</ul></fieldset>"""
    head = (
        '<link rel="stylesheet" href="/static/vendor/uplot/uPlot.min.css">\n'
        '<script src="/static/vendor/uplot/uPlot.iife.min.js"></script>\n'
        '<script type="module" src="/static/plot.js"></script>'
    )
    return page(logger, body, head=head)


def log(events: list[dict[str, Any]], *, source: str | None, limit: int) -> str:
    rows = "".join(
        f"<tr><td>{host_time(ev['time'])}</td><td>{_e(ev['source'])}</td><td>{_e(ev['kind'])}</td>"
        f'<td class="text">{_e(ev["text"])}</td></tr>'
        for ev in events
    )
    params = {"source": source} if source else {}
    links = [f'<a href="/log?{urlencode(params)}">Newest</a>']
    if len(events) == limit:
        older = urlencode({**params, "before": events[-1]["id"]})
        links.append(f'<a href="/log?{older}" rel="next">Older</a>')
    table = (
        '<div class="scroll"><table><caption>Messages and commands, newest first</caption>'
        '<thead><tr><th scope="col">Time (this computer)</th><th scope="col">Source</th>'
        '<th scope="col">Kind</th><th scope="col">Text</th></tr></thead>'
        f"<tbody>{rows}</tbody></table></div>"
        if rows
        else "<p>No events.</p>"
    )
    body = f"""<h1>Log</h1>
<form class="range" method="get" action="/log">
<div><label for="source">Source</label>
<input id="source" name="source" value="{_e(source)}"></div>
<div class="buttons"><button type="submit">Filter</button></div></form>
{table}
<nav class="pager" aria-label="Pages">{" ".join(links)}</nav>"""
    return page("Log", body, current="/log")
