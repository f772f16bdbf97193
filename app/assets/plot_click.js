(() => {
  // a click on a time plot (layout.meta.tauv_time_axis) or on the map's tracks (their points carry
  // their time) writes that time into the "Go to [s]" field (app.dashboard.plot_click); a click on
  // any other plot (a histogram, an XY plot) names no time
  if (window.__tauvPlotClick) return;
  window.__tauvPlotClick = true;
  const XPATH = __XPATH__;
  const setValue = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, 'value').set;
  let flip = false;
  function type(box, text) {
    setValue.call(box, text);
    box.dispatchEvent(new Event('input', {bubbles: true}));
  }
  function onClick(gd, ev) {
    const p = ev && ev.points && ev.points[0];
    const meta = (gd.layout && gd.layout.meta) || {};
    const t = !p ? undefined : meta.tauv === 'map' ? p.customdata : meta.tauv_time_axis ? p.x : undefined;
    if (typeof t !== 'number' || !isFinite(t)) return;
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
      if (!gd.__tauvClick) gd.__tauvClick = (ev) => onClick(gd, ev);
      if (gd._ev.listeners('plotly_click').indexOf(gd.__tauvClick) < 0) gd.on('plotly_click', gd.__tauvClick);
    }
  }
  hook();
  setInterval(hook, 500);
})();
