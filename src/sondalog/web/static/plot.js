// The plot page: loads /api/loggers/<logger>/series, draws it with the vendored uPlot
// (a global from uPlot.iife.min.js), reloads on range selection, appends live rows from
// the server-sent events stream. State is exposed for tests as window.__plots[logger] and
// as data attributes on #plot (data-state, data-series, data-points, data-live-rows).
/* global uPlot */

const form = document.getElementById("range");
const logger = form.dataset.logger;
const base = `/api/loggers/${encodeURIComponent(logger)}`;
const el = document.getElementById("plot");
const statusEl = document.getElementById("status");
const fromIn = document.getElementById("from");
const toIn = document.getElementById("to");
const liveIn = document.getElementById("live");
const csvLink = document.getElementById("csv");
const COLORS = ["#0b57d0", "#b42318", "#067647", "#b54708", "#6941c6", "#0e7090", "#c11574",
  "#4e5ba6"];

window.__plots = window.__plots || {};
let plot = null;
let current = null;
let stream = null;
let liveRows = 0;

const iso = (epoch) => new Date(Math.round(epoch) * 1000).toISOString().slice(0, 19);
// every time on the pages: YYYY-MM-DD HH:MM:SS, 24-hour, the logger's clock
const shown = (stamp) => (stamp ? stamp.replace("T", " ") : "");

// the channel's format (decimals its values show), else as uPlot would
function fmt(s) {
  return (u, v) => (v == null ? "--" : s.decimals == null ? String(v) : v.toFixed(s.decimals));
}

// a value with no drawn neighbour (null on both sides, past the join's undefined) is no
// line at all: it is drawn as a point
function lonePoints(u, si) {
  const ys = u.data[si];
  const out = [];
  const near = (i, step) => {
    for (let j = i + step; j >= 0 && j < ys.length; j += step) if (ys[j] !== undefined) return ys[j];
    return null;
  };
  for (let i = 0; i < ys.length; i++) {
    if (ys[i] != null && near(i, -1) === null && near(i, 1) === null) out.push(i);
  }
  return out;
}

function label(s) {
  const name = s.name || `channel ${s.channel}`;
  return s.unit ? `${name} [${s.unit}]` : name;
}

function joined(series, x0, x1) {
  if (series.length === 0) return [[x0, x1]];
  return uPlot.join(series.map((s) => [s.t, s.v]));
}

function expose() {
  const d = current;
  const points = d.series.map((s) => s.v.length);
  el.dataset.series = String(d.series.length);
  el.dataset.points = JSON.stringify(points);
  el.dataset.liveRows = String(liveRows);
  window.__plots[logger] = {
    series: d.series.length,
    points,
    names: d.series.map(label),
    kinds: d.series.map((s) => s.kind),
    from: d.from,
    to: d.to,
    downsampled: d.downsampled,
    liveRows,
    uplot: plot,
  };
}

function say(text) {
  statusEl.textContent = text;
}

function describe(d) {
  const most = Math.max(0, ...d.series.map((s) => s.v.length));
  const how = d.downsampled
    ? `min/max per ${d.bucket_s} s bucket`
    : "every reading";
  return `${shown(d.from)} to ${shown(d.to)} (logger clock): ${d.series.length} series, up to ${most} points each (${how})` +
    (liveRows ? `; ${liveRows} live readings added` : "");
}

function size() {
  const width = Math.max(280, el.clientWidth);
  const height = Math.max(220, Math.min(420, Math.round(window.innerHeight * 0.5)));
  return { width, height };
}

function options(d) {
  // one y axis per unit; a channel without a unit shares its scale with nothing
  const key = (s) => (s.unit ? `unit ${s.unit}` : `channel ${s.channel}`);
  const keys = [...new Set(d.series.map(key))];
  const scales = { x: { time: true, range: () => [d.x_from, Math.max(d.x_to, lastX())] } };
  // 24-hour ISO-like tick labels, as the logger writes its times
  const axes = [{
    values: [
      [86400 * 365, "{YYYY}", null, null, null, null, null, null, 1],
      [86400 * 28, "{YYYY}-{MM}", null, null, null, null, null, null, 1],
      [86400, "{MM}-{DD}", "\n{YYYY}", null, null, null, null, null, 1],
      [3600, "{HH}:{mm}", "\n{YYYY}-{MM}-{DD}", null, "\n{MM}-{DD}", null, null, null, 1],
      [60, "{HH}:{mm}", "\n{YYYY}-{MM}-{DD}", null, "\n{MM}-{DD}", null, null, null, 1],
      [1, "{HH}:{mm}:{ss}", "\n{YYYY}-{MM}-{DD}", null, "\n{MM}-{DD}", null, null, null, 1],
    ],
  }];
  keys.forEach((k, i) => {
    const first = d.series.find((s) => key(s) === k);
    scales[`u${i}`] = { auto: true };
    axes.push({
      scale: `u${i}`,
      label: first.unit || label(first),
      side: i % 2 ? 1 : 3,
      grid: { show: i === 0 },
    });
  });
  const series = [{ label: "time (logger clock)", value: (u, ts) => (ts == null ? "--" : shown(iso(ts))) }];
  d.series.forEach((s, i) => {
    const color = COLORS[i % COLORS.length];
    const box = document.getElementById(`show-${s.channel}`);
    const one = {
      label: label(s),
      stroke: color,
      scale: `u${keys.indexOf(key(s))}`,
      width: 1.5,
      show: box ? box.checked : true,
      value: fmt(s),
      points: { show: true, filter: lonePoints, size: 7, fill: color },
    };
    if (s.kind === "bars") {
      one.fill = `${color}66`;
      one.paths = uPlot.paths.bars({ size: [0.6, 8] });
      one.points = { show: false };
    }
    series.push(one);
  });
  return {
    ...size(),
    tzDate: (ts) => uPlot.tzDate(new Date(ts * 1000), "Etc/UTC"),
    scales,
    axes,
    series,
    cursor: { drag: { x: true, y: false, setScale: false } },
    hooks: {
      setSelect: [
        (u) => {
          if (u.select.width < 3) return;
          const a = u.posToVal(u.select.left, "x");
          const b = u.posToVal(u.select.left + u.select.width, "x");
          u.setSelect({ left: 0, width: 0, top: 0, height: 0 }, false);
          navigate(iso(a), iso(b));
        },
      ],
    },
  };
}

function lastX() {
  let m = 0;
  for (const s of current ? current.series : []) if (s.t.length) m = Math.max(m, s.t[s.t.length - 1]);
  return m;
}

function draw(d) {
  if (plot) plot.destroy();
  el.textContent = "";
  plot = new uPlot(options(d), joined(d.series, d.x_from, d.x_to), el);
}

function stopLive() {
  if (stream) stream.close();
  stream = null;
  delete el.dataset.live;
}

function startLive() {
  stopLive();
  if (!current || !current.following || !liveIn.checked) return;
  const since = current.last || current.to;
  stream = new EventSource(`${base}/stream?after=${encodeURIComponent(since)}`);
  stream.addEventListener("ready", () => { el.dataset.live = "connected"; });
  stream.addEventListener("readings", (ev) => {
    const data = JSON.parse(ev.data);
    let unknown = false;
    for (const [t, ch, v] of data.rows) {
      const s = current.series.find((x) => x.channel === ch);
      if (!s) { unknown = true; continue; }
      const n = s.t.length;
      const prev = n ? s.t[n - 1] : -Infinity;
      const x = t > prev ? t : prev + 0.001;
      // a pause breaks the line as on a fresh load (series.py break_gaps): a null midway
      if (s.step && n && s.v[n - 1] !== null && x - prev > 3 * s.step) {
        s.t.push((prev + x) / 2);
        s.v.push(null);
      }
      if (!s.step && n >= 2) unknown = true; // its usual step is only known from a fresh load
      s.t.push(x);
      s.v.push(v);
      liveRows += 1;
    }
    current.last = data.last;
    current.to = data.last;
    if (document.activeElement !== toIn) toIn.value = shown(data.last);
    current.x_to = Math.max(current.x_to, lastX());
    if (unknown) { load(); return; }
    plot.setData(joined(current.series, current.x_from, current.x_to));
    expose();
    say(describe(current));
  });
  stream.addEventListener("error", () => { el.dataset.live = "retrying"; });
}

async function load() {
  const q = new URLSearchParams(location.search);
  const params = new URLSearchParams();
  for (const k of ["from", "to"]) if (q.get(k)) params.set(k, q.get(k));
  el.dataset.state = "loading";
  say("Loading…");
  stopLive();
  let r;
  try {
    r = await fetch(`${base}/series?${params}`);
  } catch (err) {
    el.dataset.state = "error";
    say(`Cannot reach the dashboard: ${err}`);
    return;
  }
  const d = await r.json();
  if (!r.ok) {
    el.dataset.state = "error";
    say(`Cannot show this range: ${d.error}`);
    return;
  }
  current = d;
  liveRows = 0;
  fromIn.value = shown(d.from);
  toIn.value = shown(d.to);
  csvLink.href = `${base}/readings.csv?${new URLSearchParams({ from: d.from, to: d.to })}`;
  draw(d);
  expose();
  say(describe(d));
  el.dataset.state = "ready";
  startLive();
}

function navigate(from, to) {
  const q = new URLSearchParams();
  if (from) q.set("from", from);
  if (to) q.set("to", to);
  history.pushState(null, "", `?${q}`);
  load();
}

form.addEventListener("submit", (ev) => {
  ev.preventDefault();
  // an end left at the live end keeps following the logger
  const following = current && current.following && toIn.value === shown(current.to);
  navigate(fromIn.value.trim(), following ? null : toIn.value.trim());
});
for (const b of form.querySelectorAll("button[data-span]")) {
  b.addEventListener("click", () => {
    const end = current && current.last ? Date.parse(`${current.last}Z`) / 1000 : Date.now() / 1000;
    navigate(iso(end - Number(b.dataset.span)), null);
  });
}
for (const box of document.querySelectorAll("input[data-channel]")) {
  box.addEventListener("change", () => {
    if (!plot || !current) return;
    const i = current.series.findIndex((s) => s.channel === Number(box.dataset.channel));
    if (i >= 0) plot.setSeries(i + 1, { show: box.checked });
  });
}
liveIn.addEventListener("change", () => (liveIn.checked ? startLive() : stopLive()));
window.addEventListener("popstate", load);
window.addEventListener("resize", () => { if (plot) plot.setSize(size()); });
load();
