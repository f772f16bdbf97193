"""Judging the engine's results: error metrics, consistency (NEES and NIS) summaries, Monte Carlo
studies, replays of recorded logs against their reference, and the papers' tables."""
