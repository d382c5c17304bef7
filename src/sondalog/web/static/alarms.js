// Alarms on every page (issue 21). The Acknowledge buttons are plain forms that POST to
// /api/alarms/ID/ack; here they are sent with fetch instead, and once the dashboard has
// stored the request the button gives way to "ack requested" (the collector applies it on
// its next turn, then the alarm shows as acknowledged). On the pages that are not refreshed
// as a whole (a logger's page, the log) the parts marked data-alarm-part (the alarms, the count in
// the header) are fetched again every data-alarms-refresh seconds, unless the page is hidden
// or the keyboard focus is in that part.
const main = document.getElementById("main");

function replaceForm(form, text, failed) {
  const note = document.createElement("span");
  note.className = failed ? "ack-error" : "ack-done";
  note.setAttribute("role", failed ? "alert" : "status");
  note.textContent = text;
  if (failed) {
    form.querySelector(".ack-error")?.remove();
    form.append(" ", note);
  } else {
    form.replaceWith(note);
  }
}

document.addEventListener("submit", async (ev) => {
  const form = ev.target;
  if (!(form instanceof HTMLFormElement) || !form.classList.contains("ack")) return;
  ev.preventDefault();
  const button = form.querySelector("button");
  if (button) button.disabled = true;
  let problem;
  try {
    const r = await fetch(form.action, {
      method: "POST",
      headers: { Accept: "application/json" },
      credentials: "same-origin",
    });
    if (r.ok) {
      replaceForm(form, "ack requested", false);
      return;
    }
    const body = await r.json().catch(() => ({}));
    problem = body.error || `HTTP ${r.status}`;
  } catch (err) {
    problem = String(err);
  }
  if (button) button.disabled = false;
  replaceForm(form, `not acknowledged: ${problem}`, true);
});

async function refresh() {
  if (document.visibilityState !== "visible") return;
  try {
    const r = await fetch(location.href, { headers: { Accept: "text/html" } });
    if (!r.ok) return;
    const doc = new DOMParser().parseFromString(await r.text(), "text/html");
    for (const part of document.querySelectorAll("[data-alarm-part][id]")) {
      const fresh = doc.getElementById(part.id);
      if (!fresh || part.contains(document.activeElement)) continue;
      if (fresh.outerHTML !== part.outerHTML) part.replaceWith(fresh);
    }
  } catch {
    // the next round tries again
  }
}

const every = Number(main?.dataset.alarmsRefresh || "0") * 1000;
if (every > 0) setInterval(refresh, every);
