(() => {
  // scrolls the plot whose title starts with __TITLE__ into view once the page has drawn it (a plot
  // a checkbox adds, app.dashboard.page_scripts.scroll_to_plot): it may be drawn a moment after
  // this script arrives, so the page is asked again every 100 ms, for at most __WAIT_MS__ ms.
  const title = __TITLE__;
  const started = Date.now();
  const find = () => Array.from(document.querySelectorAll('.js-plotly-plot')).find((p) => {
    const text = p._fullLayout && p._fullLayout.title && p._fullLayout.title.text;
    return typeof text === 'string' && text.startsWith(title) && p.offsetParent !== null;
  });
  const timer = setInterval(() => {
    const plot = find();
    if (plot) {
      clearInterval(timer);
      (plot.closest('.mantine-Paper-root') || plot).scrollIntoView({block: 'nearest', behavior: 'auto'});
    } else if (Date.now() - started > __WAIT_MS__) {
      clearInterval(timer);
    }
  }, 100);
})();
