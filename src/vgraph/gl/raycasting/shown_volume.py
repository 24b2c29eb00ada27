"""What a volume renderer shows of its ``volume`` input: the voxels its transfer function (or its
2D transfer function, where one is set) gives opacity or, drawing an iso-surface, the voxels that
reach its iso level. It is said twice, in words for the scheduler's empty-image warning
(``Processor.visible_content``) and as a vgraph.shown_content.Shown for the blank-image diagnosis
(``Processor.shown_content``, vgraph.blank_causes); the RayCaster, the curvature ray casters and
the SweepPlaneRenderer say it through this one mixin.
"""

from __future__ import annotations

from vgraph.gl.raycasting.empty_space import crossed_by, visible_under
from vgraph.shown_content import voxels_reaching, voxels_under, voxels_under_2d


class ShowsVolume:
    """Mixin of a renderer with a ``volume`` inport and a ``transfer_function`` property (an
    ``iso_level`` too where ``shows_iso_surface()`` can be true); list it ahead of the
    processor's base class."""

    def shows_iso_surface(self) -> bool:
        """Whether the renderer draws the iso-surface at ``iso_level`` rather than what its
        transfer function shows (the RayCaster's ``iso`` compositing, the CurvatureRaycaster)."""
        return False

    def visible_content(self) -> str | None:
        volume = self.inputs.get("volume")
        if volume is None:
            return None
        if self.shows_iso_surface():
            return crossed_by(volume, self.iso_level)
        return visible_under(volume, self.transfer_function)

    def shown_content(self) -> list:
        volume = self.inputs.get("volume")
        if volume is None:
            return []
        if self.shows_iso_surface():
            return [voxels_reaching("volume", volume, self.iso_level)]
        if getattr(self, "transfer_function_2d", None) is not None:  # it classifies instead of the TF
            return [voxels_under_2d("volume", volume, self.transfer_function_2d)]
        return [voxels_under("volume", volume, self.transfer_function)]
