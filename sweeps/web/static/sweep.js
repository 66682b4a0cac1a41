// The sweep page's header follows its sweep while it runs (same endpoint and cursor as
// the catalogue); the maps are plain <img> tags drawn by the server.
"use strict";
(function () {
  const box = document.getElementById("sweep-live");
  if (!box) return;
  const id = box.dataset.id;
  let cursor = "0";
  async function poll() {
    try {
      const r = await fetch("/api/sweeps?after=" + encodeURIComponent(cursor),
                            {credentials: "same-origin"});
      if (r.ok) {
        const data = await r.json();
        cursor = String(data.cursor);
        for (const row of data.sweeps) {
          if (row.sweep_id !== id) continue;
          for (const f of ["state_text", "done_points", "failed_points"]) {
            const el = box.querySelector('[data-f="' + f + '"]');
            if (el) el.textContent = row[f];
          }
        }
      }
    } catch (e) { /* the server is gone: try again later */ }
    setTimeout(poll, 2000);
  }
  setTimeout(poll, 2000);
})();
