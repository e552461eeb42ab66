"""Ordered processors: each takes the IR (and the asset store) and returns a new IR."""
