"""The dashboard (``tauv serve``): the viser server (app.dashboard.server), each browser tab's
session built of rooms around its shared state (controls, scene, playback, plots, runs, vehicle),
the controls' table and checks, the page's address, the scripts it runs in the page, the worker
processes that run the missions and their memory budget, the downloads."""
