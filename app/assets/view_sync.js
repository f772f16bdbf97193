(() => {
  // one time axis for the page (app.dashboard.page_scripts.view_sync): the store window.__tauv = {t_s, x_range}
  // holds the time cursor [s] and the zoomed time range ([lo, hi] s, null: each plot's own); every
  // plot tagged a time plot (layout.meta.tauv_time_axis, app.figures.shared.with_cursor) shows them
  // whenever it is drawn, and a zoom, pan or reset of one is fanned out to all the others
  const S = window.__tauv = window.__tauv || {t_s: null, x_range: null};
  if (S.installed) return;
  S.installed = true;
  const CURSOR = __CURSOR_NAME__;
  const BUSY_DELAY_MS = __BUSY_DELAY_MS__;
  const ADDRESS_DELAY_MS = 400;
  const kept = new Set();  // plots hidden (not unmounted) whose Plotly state is kept for their return

  const isTime = (gd) => !!(gd && gd.layout && gd.layout.meta && gd.layout.meta.tauv_time_axis);
  const plots = () => Array.from(document.querySelectorAll('.js-plotly-plot')).filter(
    (gd) => gd.data && isTime(gd));
  // the plots of the tab in view: a hidden tab's plots are drawn anew when it is shown (their width
  // changes), and patchLayout and the afterplot hook give them the store's cursor and range then
  const shown = () => plots().filter((gd) => gd.offsetParent !== null);
  const xAxes = (layout) => Object.keys(layout || {}).filter((k) => /^xaxis\d*$/.test(k));
  const same = (a, b) => a === b || (a && b && Math.abs(a[0] - b[0]) < 1e-9 && Math.abs(a[1] - b[1]) < 1e-9);
  const cursorIndex = (shapes) => (shapes || []).findIndex((s) => s && s.name === CURSOR);

  function patchLayout(layout) {
    // a figure about to be drawn: the store's cursor and range written into its layout (one draw)
    if (!layout || !layout.meta || !layout.meta.tauv_time_axis) return;
    const k = cursorIndex(layout.shapes);
    if (k >= 0 && S.t_s !== null) {
      layout.shapes = layout.shapes.slice();
      layout.shapes[k] = Object.assign({}, layout.shapes[k], {x0: S.t_s, x1: S.t_s});
    }
    if (S.x_range) {
      for (const ax of xAxes(layout)) {
        layout[ax] = Object.assign({}, layout[ax], {range: S.x_range.slice(), autorange: false});
      }
    }
  }

  function edits(gd) {
    // what gd lacks of the store: the cursor's x0/x1 only (not the whole shapes array), its x ranges
    const out = {};
    const shapes = gd.layout.shapes || [];
    const k = cursorIndex(shapes);
    if (k >= 0 && S.t_s !== null && (shapes[k].x0 !== S.t_s || shapes[k].x1 !== S.t_s)) {
      out[`shapes[${k}].x0`] = S.t_s;
      out[`shapes[${k}].x1`] = S.t_s;
    }
    const full = gd._fullLayout || {};
    for (const ax of xAxes(full)) {
      if (S.x_range) {
        if (!same(full[ax].range, S.x_range)) out[`${ax}.range`] = S.x_range.slice();
      } else if (S.reset && full[ax].autorange !== true) {
        out[`${ax}.autorange`] = true;
      }
    }
    return out;
  }

  function apply(gd) {
    if (!window.Plotly || !gd.data || !isTime(gd)) return;
    const out = edits(gd);
    if (Object.keys(out).length) window.Plotly.relayout(gd, out);
  }

  function fromEvent(ev) {
    // the x range a plotly_relayout names: [lo, hi], 'auto' (reset), or undefined (none)
    for (const key of Object.keys(ev || {})) {
      let m = /^(xaxis\d*)\.range\[0\]$/.exec(key);
      if (m && (m[1] + '.range[1]') in ev) return [+ev[key], +ev[m[1] + '.range[1]']];
      m = /^xaxis\d*\.range$/.exec(key);
      if (m && Array.isArray(ev[key])) return [+ev[key][0], +ev[key][1]];
      if (/^xaxis\d*\.autorange$/.test(key) && ev[key]) return 'auto';
    }
    return undefined;
  }

  function onRelayout(gd, ev) {
    if (!isTime(gd)) return;
    const r = fromEvent(ev);
    if (r === undefined) return;
    if (r === 'auto') {
      if (S.x_range === null) return;  // an echo of the fan-out (or nothing to reset)
      S.x_range = null;
      S.reset = true;
    } else {
      if (!isFinite(r[0]) || !isFinite(r[1]) || same(r, S.x_range)) return;
      S.x_range = r;
      S.reset = false;
    }
    for (const other of shown()) apply(other);
    writeAddress();
  }

  function hook(gd) {
    if (typeof gd.on !== 'function' || !gd._ev || gd.__tauvHooked === gd._ev) return;
    gd.__tauvHooked = gd._ev;  // a purged and redrawn plot has a new emitter: hooked again
    gd.on('plotly_relayout', (ev) => onRelayout(gd, ev));
    gd.on('plotly_afterplot', () => apply(gd));
  }

  // ------------------------------------------------------------------ the page's address
  let addressTimer = null;
  function viewQuery(search) {
    // ``search`` with the page's own view keys (t: the cursor, x: the zoomed range) written
    // (x always the page's; t the server's until the page has a time)
    const params = search.replace(/^\?/, '').split('&').filter(
      (p) => p && !/^x=/.test(p) && !(S.t_s !== null && /^t=/.test(p)));
    if (S.t_s !== null) params.push('t=' + (+S.t_s.toFixed(2)));
    if (S.x_range) params.push('x=' + S.x_range.map((v) => +v.toFixed(3)).join(':'));
    return '?' + params.join('&');
  }
  function writeAddress() {
    if (!S.addressReady) return;
    clearTimeout(addressTimer);
    addressTimer = setTimeout(() => {
      const q = viewQuery(window.location.search);
      if (q !== window.location.search) history.replaceState(history.state, '', q + window.location.hash);
    }, ADDRESS_DELAY_MS);
  }

  // ------------------------------------------------------------------ what the server calls
  let cursorPending = false;
  S.setTime = (t) => {
    // moves arriving faster than the page draws are merged into one edit per plot
    S.t_s = +t;
    writeAddress();
    if (cursorPending) return;
    cursorPending = true;
    requestAnimationFrame(() => {
      cursorPending = false;
      for (const gd of shown()) apply(gd);
    });
  };
  S.setRange = (r) => {
    S.x_range = r ? [+r[0], +r[1]] : null;
    S.reset = !r;
    for (const gd of shown()) apply(gd);
    writeAddress();
  };
  S.setAddress = (query) => {
    // the server's query (the controls, the camera) with the page's view keys
    S.addressReady = true;
    history.replaceState(history.state, '', viewQuery(query) + window.location.hash);
  };
  let busyTimer = null;
  S.busy = (on) => {
    clearTimeout(busyTimer);
    let el = document.getElementById('tauv-busy');
    if (!on) {
      if (el) el.style.display = 'none';
      return;
    }
    busyTimer = setTimeout(() => {
      if (!el) {
        el = document.createElement('div');
        el.id = 'tauv-busy';
        el.setAttribute('role', 'status');
        el.textContent = 'Working…';
        el.style.cssText = 'position:fixed;top:8px;left:50%;transform:translateX(-50%);z-index:10000;'
          + 'padding:4px 12px;border-radius:12px;background:rgba(30,30,30,0.8);color:#fff;font-size:13px;'
          + 'pointer-events:none';
        document.body.appendChild(el);
      }
      el.style.display = 'block';
    }, BUSY_DELAY_MS);
  };

  // ------------------------------------------------------------------ plotly's entry points
  function wrap() {
    const P = window.Plotly;
    if (!P || P.__tauvWrapped) return !!P;
    P.__tauvWrapped = true;
    for (const name of ['react', 'newPlot']) {
      const original = P[name];
      P[name] = function (gd, data, layout, config) {
        if (layout && !Array.isArray(layout)) patchLayout(layout);
        const done = original.apply(this, arguments);
        kept.delete(gd);
        return Promise.resolve(done).then((out) => {
          if (gd && gd.classList) { hook(gd); apply(gd); }
          return out;
        });
      };
    }
    // a plot of a tab being hidden is kept as drawn (its node stays in the page): shown again it
    // is the same plot, not a new one drawn from its figure; a plot taken off the page is purged
    const purge = P.purge;
    P.purge = function (gd) {
      if (gd && gd.isConnected) { kept.add(gd); return gd; }
      return purge.apply(this, arguments);
    };
    setInterval(() => {
      for (const gd of Array.from(kept)) if (!gd.isConnected) { kept.delete(gd); purge.call(P, gd); }
    }, 5000);
    return true;
  }
  if (!wrap()) {
    const wait = setInterval(() => { if (wrap()) clearInterval(wait); }, 50);
  }
  for (const gd of document.querySelectorAll('.js-plotly-plot')) { hook(gd); apply(gd); }
})();
