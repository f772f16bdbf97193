(() => {
  // the map's cursor (app.dashboard.session_map): only its cursor traces move (Plotly.restyle of
  // their points), on the map figure of the results they were reckoned for (layout.meta.key). The
  // latest is kept and put back whenever the map is drawn afresh (a new figure, a resize, its tab
  // shown again: plotly makes a new _fullLayout each time)
  window.__tauvMap = {key: __KEY__, first: __FIRST__, x: __X__, y: __Y__,
                      serial: ((window.__tauvMap && window.__tauvMap.serial) || 0) + 1};
  function apply() {
    const m = window.__tauvMap;
    if (!window.Plotly || !m) return;
    for (const gd of document.querySelectorAll('.js-plotly-plot')) {
      const meta = gd.layout && gd.layout.meta;
      if (!meta || meta.tauv !== 'map' || meta.key !== m.key || !gd._fullLayout) continue;
      if (gd.offsetParent === null) continue;  // its tab hidden: restyled when shown (the interval below)
      if (gd._fullLayout.__tauvMapSerial === m.serial) continue;
      if (!gd.data || gd.data.length < m.first + m.x.length) continue;
      gd._fullLayout.__tauvMapSerial = m.serial;
      const indices = m.x.map((_, i) => m.first + i);
      window.Plotly.restyle(gd, {x: m.x, y: m.y}, indices);
    }
  }
  apply();
  if (!window.__tauvMapHook) window.__tauvMapHook = setInterval(apply, 300);
})();
