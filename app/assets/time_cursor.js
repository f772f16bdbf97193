(() => {
  // the shared time cursor: every plotly plot of the page gets a vertical line at the slider's
  // time; moves arriving faster than the page draws are merged into one relayout
  window.__tauvCursor = __T__;
  if (window.__tauvCursorPending) return;
  window.__tauvCursorPending = true;
  setTimeout(() => {
    window.__tauvCursorPending = false;
    if (!window.Plotly) return;
    const t = window.__tauvCursor;
    const shape = __SHAPE__;
    shape.x0 = t; shape.x1 = t;
    for (const p of document.querySelectorAll('.js-plotly-plot')) {
      if (p.layout && p.layout.meta && p.layout.meta.tauv === 'map') continue;  // not a time axis
      if (p.layout && p.data && p.data.length) window.Plotly.relayout(p, {shapes: [shape]});
    }
  }, 80);
})();
