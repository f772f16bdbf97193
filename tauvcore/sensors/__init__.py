"""Sensor models: each a frozen ``*Config`` (Table 2 defaults, paper units in the field names)
and ``simulate(truth, config, rng, num_runs=None)``. With ``num_runs=R`` every output gets a run
axis after time: ``(K, R, ...)``; without it, ``(K, ...)``."""
