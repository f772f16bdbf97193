"""The ``tauv`` subcommands' names and one-line help, and the program's description: what
``tauv --help`` prints (app.entry, without loading any command) and what app.cli builds its
parser from. Plain strings: importing this loads nothing else."""

from __future__ import annotations

PROG = "tauv"
DESCRIPTION = "Underwater INS/DVL navigation lab (Tal, Klein & Katz 2017)."
COMMANDS = {
    "run": "simulate a mission and run fusion methods side by side",
    "replay": "run the fusion methods on a recorded log (a directory of sensor tables, a ROS bag or an MCAP file)",
    "calibrate": "estimate the DVL's mounting misalignment and scale factor and the IMU-to-reference boresight "
    "from logs with a reference, and write them as a [calibration] section",
    "tune": "find the filter's noise parameters from recorded logs (maximum likelihood of the innovations)",
    "mc": "Monte Carlo study: N seeded runs, summary.json, runs.parquet and report.html",
    "reproduce": "the first paper's study: 3 trajectories, beams 3 and 4 lost, 100 runs, "
    "with every figure of its section 4.2 beside ours",
    "serve": "start the browser dashboard",
    "log": "what a ROS bag holds, and a bag written as a log",
    "config": "print the full configuration as TOML",
}
"""Every subcommand and its one-line help, in the order ``tauv --help`` lists them."""
