// The overview refreshes itself: every data-refresh seconds (on <main>) it fetches the page
// again and swaps in the new content, unless the page is hidden or the keyboard focus is in
// it (so a reader tabbing through is never moved).
const main = document.getElementById("main");
const every = Number(main.dataset.refresh || "10") * 1000;

async function refresh() {
  if (document.visibilityState !== "visible" || main.contains(document.activeElement)) return;
  try {
    const r = await fetch(location.href, { headers: { Accept: "text/html" } });
    if (!r.ok) return;
    const doc = new DOMParser().parseFromString(await r.text(), "text/html");
    const fresh = doc.getElementById("main");
    if (fresh && fresh.innerHTML !== main.innerHTML) main.innerHTML = fresh.innerHTML;
    // the count of active alarms in the header
    const count = doc.getElementById("alarm-count");
    const shown = document.getElementById("alarm-count");
    if (count && shown && count.outerHTML !== shown.outerHTML) shown.replaceWith(count);
    main.dataset.refreshed = String(Number(main.dataset.refreshed || "0") + 1);
  } catch {
    // the next round tries again
  }
}

setInterval(refresh, every);
