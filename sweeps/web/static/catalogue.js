// Live progress of the catalogue: poll /api/sweeps?after=CURSOR (once a second while
// the page is visible) and update the changed rows in place. Text only (textContent):
// values from the store are never parsed as HTML.
"use strict";
(function () {
  const table = document.getElementById("catalogue");
  if (!table) return;
  const status = document.getElementById("live-status");
  let cursor = table.dataset.cursor || "0";
  const PERIOD_MS = 1000;

  function eta(s) { return s === null || s === undefined ? "" : Math.round(s) + " s"; }

  function update(row) {
    const tr = table.querySelector('tr[data-id="' + CSS.escape(row.sweep_id) + '"]');
    if (!tr) return false;
    const set = (field, text) => {
      const el = tr.querySelector('[data-f="' + field + '"]');
      if (el && el.textContent !== String(text)) el.textContent = text;
    };
    set("state_text", row.state_text);
    set("done_points", row.done_points);
    set("n_points", row.n_points);
    set("failed_points", row.failed_points);
    set("eta", eta(row.eta_s));
    set("finished", (row.finished || "").slice(0, 19));
    set("warnings", row.warnings.length ? String(row.warnings.length) : "");
    const bar = tr.querySelector("progress");
    if (bar) { bar.max = row.n_points || 1; bar.value = row.done_points; }
    tr.className = "state-" + row.state;
    return true;
  }

  async function poll() {
    if (document.visibilityState === "visible") {
      try {
        const r = await fetch("/api/sweeps?after=" + encodeURIComponent(cursor),
                              {credentials: "same-origin"});
        if (r.ok) {
          const data = await r.json();
          let unknown = 0;
          for (const row of data.sweeps) if (!update(row)) unknown++;
          cursor = String(data.cursor);
          status.textContent = unknown ? "live (" + unknown + " new: reload to list)" : "live";
        } else {
          status.textContent = "live updates paused (" + r.status + ")";
        }
      } catch (e) {
        status.textContent = "live updates paused (server unreachable)";
      }
    }
    setTimeout(poll, PERIOD_MS);
  }
  setTimeout(poll, PERIOD_MS);
})();
