"""Volumes larger than memory: a multiresolution pyramid of bricks (docs/guide/large-data.md)."""
