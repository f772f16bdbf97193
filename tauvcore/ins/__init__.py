"""Strapdown INS (pure step) and its error model (F, G, Q, discretisation)."""
