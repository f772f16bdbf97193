"""Write the DVL's pings as they were before water-track, the seeded reference that
``tests/unit/tauvcore/sensors/test_water_track.py`` holds ``dvl.water_track = "off"`` to, bit for bit.

    python scripts/make_dvl_reference.py tests/fixtures/dvl_reference.npz

Generated at commit f5afa24 (the last before water-track). Four cases over a 40 s figure eight
whose beams cross the DVL's range as it rolls (seabed 60 m, bottom lock to 40.2 m altitude), with
dropout and a scheduled outage: the whole-mission ``simulate`` with bottom lock "lost" and
"noisy" (two runs, one generator), without a seabed (one run), and the aiding source chunk by
chunk from spawned streams (two runs, chunks of 77 samples). Only the API of that commit is used
here, so that the same script rebuilds the same pings today.
"""

from __future__ import annotations

import sys

import numpy as np

from tauvcore.aiding import dvl_beams
from tauvcore.config import Config
from tauvcore.engine.source_streams import SourceStream
from tauvcore.geo.earth import Earth
from tauvcore.sensors import dvl
from tauvcore.sensors.dvl import Outage
from tauvcore.sensors.stream import SensorStreams
from tauvcore.truth import TrajectoryConfig, generate
from tauvcore.truth.kinematic import TruthStream, bathymetry

RATE_HZ = 100.0
FIELDS = ("t_s", "index", "y_beam_mps", "available", "bias_mps", "scale_factor", "slant_range_m")
TRAJECTORY = TrajectoryConfig(name="figure8", duration_s=40.0, depth_m=20.0, seabed_depth_m=60.0)
DVL = {"rate_hz": 5.0, "max_altitude_m": 40.2, "dropout_probability": 0.1, "outages": (Outage((2,), 10.0, 14.0),)}


def cases() -> dict[str, dvl.DvlData]:
    """The four cases' pings (module docstring), by name."""
    truth = generate(TRAJECTORY, Earth(), RATE_HZ)
    seabed = bathymetry(TRAJECTORY)
    out = {}
    for mode in ("lost", "noisy"):
        config = dvl.DvlConfig(**DVL, beyond_range=mode)
        out[mode] = dvl.simulate(truth, config, np.random.default_rng(3), 2, seabed)
    out["no_seabed"] = dvl.simulate(truth, dvl.DvlConfig(**DVL), np.random.default_rng(4))
    stream = TruthStream(TRAJECTORY, Earth(), RATE_HZ, 77)
    config = Config(trajectory=TRAJECTORY, dvl=dvl.DvlConfig(**DVL))
    streams = SensorStreams.spawned(np.random.default_rng(5))
    sources = SourceStream(config, np.random.default_rng(0), 2, stream.num_samples, stream.dt_s, streams)
    parts = [dvl_beams.pings(sources.next_chunk(k0, chunk)["dvl"], 2) for k0, chunk in stream]
    out["stream"] = dvl.DvlData(
        **{f: np.concatenate([getattr(p, f) for p in parts]) for f in FIELDS if f != "slant_range_m"}
    )
    return out


def arrays(pings: dict[str, dvl.DvlData] | None = None) -> dict[str, np.ndarray]:
    """Every case's fields as ``<case>/<field>`` (fields that are None left out), of ``pings``
    (:func:`cases`' by default)."""
    return {
        f"{name}/{f}": np.asarray(getattr(data, f))
        for name, data in (cases() if pings is None else pings).items()
        for f in FIELDS
        if getattr(data, f) is not None
    }


if __name__ == "__main__":
    np.savez_compressed(sys.argv[1], **arrays())
