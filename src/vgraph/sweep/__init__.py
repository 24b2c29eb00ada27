"""RZSweep (Retondaro 2008; ZSweep by Farias, Mitchell and Silva 2000): sweep-plane cell
projection of a regular grid on the CPU, compiled with numba (docs/explanations/sweep-plane.md).

- grid: the swept grid (vertex positions and depths, values, threshold classification)
- kernel: the sweep itself (heap of vertex events, face projection into per-pixel lists, lazy
  compositing at target-z events)
- render: the public entry point, an image in the ray casters' conventions
"""
