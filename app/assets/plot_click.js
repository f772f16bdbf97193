(() => {
  // a click on any plotly figure writes its time into the "Go to [s]" field (app.dashboard.plot_click)
  if (window.__tauvPlotClick) return;
  window.__tauvPlotClick = true;
  const XPATH = __XPATH__;
  const setValue = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, 'value').set;
  let flip = false;
  function type(box, text) {
    setValue.call(box, text);
    box.dispatchEvent(new Event('input', {bubbles: true}));
  }
  function onClick(ev) {
    const p = ev && ev.points && ev.points[0];
    // a point that carries its time (the map's tracks) names that time; else its x does
    const t = p && p.customdata !== undefined ? p.customdata : p && p.x;
    if (!p || typeof t !== 'number' || !isFinite(t)) return;
    const box = document.evaluate(XPATH, document, null, XPathResult.FIRST_ORDERED_NODE_TYPE, null)
      .singleNodeValue;
    if (!box) return;
    // a trailing space every other click: the same time clicked twice is still a change (viser
    // sends a field's latest value only, so clearing it first would not reach the server)
    flip = !flip;
    type(box, t.toFixed(2) + (flip ? ' ' : ''));
  }
  function hook() {
    for (const gd of document.querySelectorAll('.js-plotly-plot')) {
      // a figure redrawn by Plotly.newPlot loses its listeners: hook it again
      if (typeof gd.on !== 'function' || !gd._ev) continue;
      if (gd._ev.listeners('plotly_click').indexOf(onClick) < 0) gd.on('plotly_click', onClick);
    }
  }
  hook();
  setInterval(hook, 500);
})();
