"""Running scenarios (simulation + filters side by side) and the metrics that judge them."""
