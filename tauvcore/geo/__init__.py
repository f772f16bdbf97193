"""Earth model and rotation algebra (see tauvcore.conventions)."""
