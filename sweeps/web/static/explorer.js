// The explorer: says "computing" from the click until both images have arrived, and how
// long that took (click to image).
"use strict";
(function () {
  const form = document.getElementById("explorer-form");
  const status = document.getElementById("explorer-status");
  if (!form || !status) return;
  form.addEventListener("submit", () => {
    sessionStorage.setItem("ditherlab-click", String(Date.now()));
    status.textContent = "computing...";
  });
  const imgs = [document.getElementById("chart"), document.getElementById("curves")]
    .filter(Boolean);
  if (!imgs.length) return;
  const clicked = Number(sessionStorage.getItem("ditherlab-click") || 0);
  let left = imgs.length;
  const done = (img) => {
    if (img.naturalWidth === 0) status.textContent = "the server could not draw " + img.alt;
    if (--left > 0) return;
    if (clicked) status.textContent = "click to image: " + (Date.now() - clicked) + " ms";
    sessionStorage.removeItem("ditherlab-click");
  };
  for (const img of imgs) {
    if (img.complete) done(img);
    else {
      img.addEventListener("load", () => done(img));
      img.addEventListener("error", () => done(img));
    }
  }
})();
