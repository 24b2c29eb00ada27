"""Volumes larger than memory: a multiresolution pyramid of bricks (docs/large-data.md)."""
