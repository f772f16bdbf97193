(() => {
  // what the server asks of the page (app.dashboard.page_scripts.report): the address's query, and every
  // control of __IDS__ as the page shows it: checkboxes by their input's id, the other inputs
  // through their label (viser labels each input's row with label[for=id])
  const out = {};
  for (const id of __IDS__) {
    let el = document.getElementById(id);
    if (!(el instanceof HTMLInputElement)) {
      const label = document.querySelector('label[for="' + id + '"]');
      const row = label && label.parentElement && label.parentElement.parentElement;
      const box = row && row.nextElementSibling;
      el = box ? box.querySelector('input:not([type=hidden]), textarea') : null;
    }
    if (el) out[id] = el.type === "checkbox" ? el.checked : el.value;
  }
  // answers older than a minute were read long ago (or never will be): drop them here, since a
  // removal sent by the server would wait for a 3-D frame and hold up the notification behind it
  const now = Date.now();
  for (const k of Object.keys(localStorage)) {
    if (!k.startsWith(__PREFIX__)) continue;
    let t = 0;
    try { t = JSON.parse(localStorage.getItem(k)).t || 0; } catch (e) {}
    if (now - t > 60000) localStorage.removeItem(k);
  }
  localStorage.setItem(__KEY__, JSON.stringify({t: now, search: window.location.search, values: out}));
})();
