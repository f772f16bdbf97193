(() => {
  // marks the controls whose values cannot run (app.dashboard.control_checks, app.dashboard.page_scripts.mark): a red
  // outline, aria-invalid and the message as the tooltip; clears the marks of the others; with
  // __SCROLL__ the first marked control is scrolled into view. __BAD__: viser id -> message.
  const bad = __BAD__;
  const input = (id) => {
    const label = document.querySelector('label[for="' + id + '"]');
    const row = label && label.parentElement && label.parentElement.parentElement;
    const box = row && row.nextElementSibling;
    return box ? box.querySelector('input:not([type=hidden]), textarea') : null;
  };
  for (const el of document.querySelectorAll('[data-tauv-invalid]')) {
    el.removeAttribute('data-tauv-invalid');
    el.removeAttribute('aria-invalid');
    el.style.outline = '';
    el.title = '';
  }
  let first = null;
  for (const [id, message] of Object.entries(bad)) {
    const el = input(id);
    if (!el) continue;
    el.setAttribute('data-tauv-invalid', '1');
    el.setAttribute('aria-invalid', 'true');
    el.style.outline = '2px solid #e03131';
    el.title = message;
    if (first === null) first = el;
  }
  if (__SCROLL__ && first !== null) first.scrollIntoView({block: 'center'});
})();
