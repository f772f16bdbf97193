(() => {
  // ties every control's label to its input (app.dashboard.page_scripts.label_inputs): viser labels an
  // input's row (label[for=row]), not the input, so screen readers and get_by_label find no
  // name. Each input gets its label's text as aria-label, now and whenever controls are added.
  if (window.__tauvLabelInputs) return;
  window.__tauvLabelInputs = true;
  const tie = () => {
    for (const label of document.querySelectorAll('label[for]')) {
      const row = label.parentElement && label.parentElement.parentElement;
      const box = row && row.nextElementSibling;
      const el = box ? box.querySelector('input:not([type=hidden]), textarea') : null;
      const name = label.textContent.trim();
      if (el && name && el.getAttribute('aria-label') !== name) el.setAttribute('aria-label', name);
    }
  };
  let pending = null;
  const later = () => {
    if (pending === null) pending = setTimeout(() => { pending = null; tie(); }, 250);
  };
  tie();
  new MutationObserver(later).observe(document.body, {subtree: true, childList: true});
})();
