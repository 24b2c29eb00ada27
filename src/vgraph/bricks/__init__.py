"""Volumes larger than memory: a multiresolution pyramid of bricks (docs/guide/large-data.md).

The stores and bricked volumes; vgraph.io opens them (read_volume) and writes them (vgraph.io.convert),
so nothing here imports vgraph.io."""
