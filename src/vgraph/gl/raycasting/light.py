"""Blinn-Phong lighting (Inácio 2009 ch. 4.3), shared by every ray caster: its uniforms."""

from __future__ import annotations

import numpy as np

from vgraph.errors import VGraphError
from vgraph.numerics.reference_raycast import GRADIENT_EPSILON


def shading_uniforms(owner, min_spacing: float, frame=None) -> dict[str, object]:
    """Uniforms of raycasting/shading.glsl from ``owner``'s lighting properties; gradients at or
    below GRADIENT_EPSILON / min(spacing) leave a sample unshaded, as in the CPU reference. The
    light direction (world) is turned into ``frame`` (a vgraph.box_frame.BoxFrame) where the
    gradients are."""
    light = np.asarray(owner.light_direction, dtype=np.float64)
    largest = np.abs(light).max()
    if owner.light == "direction" and not largest > 0.0:
        raise VGraphError(f"{owner.id}.light_direction must not be zero, got {list(light)}")
    light = light / largest if largest > 0.0 else light  # scaled first: |(1e308,)*3| overflows
    if frame is not None:
        light = frame.directions(light)
    return {"gradient_epsilon": GRADIENT_EPSILON / min_spacing,
            "light_direction": tuple(float(v) for v in light / max(np.linalg.norm(light), 1e-300)),
            "ambient": owner.ambient, "diffuse": owner.diffuse, "specular": owner.specular,
            "shininess": owner.shininess}


