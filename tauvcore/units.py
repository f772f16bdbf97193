"""Named conversion factors from the units used at the edges (papers, config files, CLI, GUI)
to SI. Multiply a value in the named unit by the constant to get SI; divide to go back.

>>> 3.0 * DEG_PER_HOUR   # 3 deg/h in rad/s
"""

import math

DEG = math.pi / 180.0
"""One degree in radians."""
HOUR = 3600.0
"""One hour in seconds."""
SQRT_HOUR = 60.0
"""sqrt(3600 s) in sqrt(s)."""
G0 = 9.80665
"""Standard gravity [m/s^2]; defines the milli-g (not the local gravity used by the INS)."""
MG = 1e-3 * G0
"""One milli-g in m/s^2."""
DEG_PER_HOUR = DEG / HOUR
"""One deg/h in rad/s."""
DEG_PER_SQRT_HOUR = DEG / SQRT_HOUR
"""One deg/sqrt(h) (angle random walk) in rad/sqrt(s)."""
MPS_PER_SQRT_HOUR = 1.0 / SQRT_HOUR
"""One m/s/sqrt(h) (velocity random walk) in m/s/sqrt(s)."""
PERCENT = 1e-2
"""One percent as a fraction."""

KNOT = 1852.0 / 3600.0
"""One knot [m/s] (a nautical mile, 1852 m, per hour)."""
