"""The engine: the filter banks run over a mission chunk by chunk.

Truth and sensors (a simulation, or a recorded log) come in as chunks
(:mod:`tauvcore.engine.simulation`); the 20-state bank of the first paper's methods
(:mod:`tauvcore.engine.filter_bank`) and Yoo 2014's 12-state bank
(:mod:`tauvcore.engine.yoo_bank`) run side by side over them (:mod:`tauvcore.engine.mission`:
:func:`~tauvcore.engine.mission.run`, :func:`~tauvcore.engine.mission.run_streaming`), from the
start of :mod:`tauvcore.engine.start`, and hand out :mod:`tauvcore.engine.results`: per-epoch
errors, sigmas and NEES, and a record of every update (:mod:`tauvcore.engine.recorder`), judged
as they go by the divergence monitor (:mod:`tauvcore.engine.monitor`). Judging results against
the papers and over Monte Carlo studies is :mod:`tauvcore.eval`'s.
"""
