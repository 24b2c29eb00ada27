"""What other tools put around an OME-Zarr image, beyond the NGFF metadata store_metadata.py
checks: bioformats2raw's collection of images (layout 3), label images ("image-label"), spatial
axes in different length units, and the bricks of chunks of any shape (docs/guide/large-data.md,
"Stores from other tools"). Problems raise VolumeFileError naming the store and the field.
"""

from __future__ import annotations

import warnings

from vgraph.errors import VGraphWarning, VolumeFileError


class StoreImagesWarning(VGraphWarning):
    """A bioformats2raw collection holds more than one image: the first is shown (the layout asks
    readers to say so)."""


class StoreUnitsWarning(VGraphWarning):
    """The spatial axes of an OME-Zarr image name different units that are not known lengths, so
    their scales cannot be brought to one unit: they are used as they are."""


# Metres per unit: the UDUNITS-2 length names NGFF 0.4/0.5 list for space axes.
_LENGTHS = {"angstrom": 1e-10, "attometer": 1e-18, "centimeter": 1e-2, "decimeter": 1e-1,
            "exameter": 1e18, "femtometer": 1e-15, "foot": 0.3048, "gigameter": 1e9, "hectometer": 1e2,
            "inch": 0.0254, "kilometer": 1e3, "megameter": 1e6, "meter": 1.0, "micrometer": 1e-6,
            "mile": 1609.344, "millimeter": 1e-3, "nanometer": 1e-9, "parsec": 3.0856775814913673e16,
            "petameter": 1e15, "picometer": 1e-12, "terameter": 1e12, "yard": 0.9144,
            "yoctometer": 1e-24, "yottameter": 1e24, "zeptometer": 1e-21, "zettameter": 1e21}

# Another tool's chunks are any shape (bioformats2raw: one plane of 1024 x 1024): its bricks take
# whole chunks, grown to MIN_BRICK or split to MAX_BRICK voxels per edge, so a brick is neither a
# sliver mostly of halo nor a texture of a gigabyte.
MIN_BRICK, MAX_BRICK = 16, 256


def foreign_brick(chunks) -> tuple[int, int, int]:
    """The brick (x, y, z) of another tool's image from its chunk: an edge below MIN_BRICK grows
    to whole chunks, one above MAX_BRICK is split evenly into pieces of at most MAX_BRICK."""
    return tuple(c * -(-MIN_BRICK // c) if c < MIN_BRICK else -(-c // -(-c // MAX_BRICK)) for c in chunks)


def space_units(axes: list[dict], space: list, path) -> tuple[str | None, tuple[float, float, float]]:
    """The unit of the volume's world (the first spatial axis's that names one) and, per axis
    (x, y, z), the factor that brings that axis's scale and translation to it: spatial axes in
    micrometer and nanometer give one world in micrometer."""
    units = [axes[a].get("unit") if a is not None else None for a in space[::-1]]  # x, y, z
    named = [u for u in units if isinstance(u, str) and u]
    if not named:
        return None, (1.0, 1.0, 1.0)
    unit = next(u for u in units[::-1] if isinstance(u, str) and u)  # z's first, as the axes list them
    if all(u in _LENGTHS for u in named):
        return unit, tuple(_LENGTHS[u] / _LENGTHS[unit] if isinstance(u, str) and u else 1.0 for u in units)
    if len(set(named)) > 1:
        warnings.warn(StoreUnitsWarning(
            f"{path}: the spatial axes are in {', '.join(sorted(set(named)))}, not all known lengths: "
            f"their scales are used as they are"), stacklevel=3)
    return unit, (1.0, 1.0, 1.0)


# --- labels --------------------------------------------------------------------------------------------
def is_label_image(attributes: dict) -> bool:
    """Whether the image is a label image: its metadata has "image-label" (NGFF 0.4 at the top,
    0.5 under "ome"), as the images in an image's labels/ group do."""
    ome = attributes.get("ome") if isinstance(attributes.get("ome"), dict) else attributes
    return isinstance(ome.get("image-label"), dict) or isinstance(attributes.get("image-label"), dict)


# --- bioformats2raw -----------------------------------------------------------------------------------
def bioformats2raw_layout(attributes: dict) -> bool:
    """Whether the group is bioformats2raw's collection of images (layout 3: the images in
    groups "0", "1", ... or as listed by OME/ "series"), NGFF 0.4 or 0.5."""
    ome = attributes.get("ome") if isinstance(attributes.get("ome"), dict) else attributes
    return "multiscales" not in ome and (ome.get("bioformats2raw.layout") is not None
                                         or attributes.get("bioformats2raw.layout") is not None)


def check_bioformats2raw(attributes: dict, path) -> None:
    ome = attributes.get("ome") if isinstance(attributes.get("ome"), dict) else attributes
    version = ome.get("bioformats2raw.layout", attributes.get("bioformats2raw.layout"))
    if version != 3:
        raise VolumeFileError(path, f"bioformats2raw layout {_short(version)}: vgraph reads layout 3",
                              "bioformats2raw.layout")
    if "plate" in ome:
        raise VolumeFileError(path, "a bioformats2raw plate (high-content screening): open one "
                                    "field's image group (ROW/COLUMN/FIELD) instead", "plate")


def series_paths(ome_attributes: dict | None, path) -> list[str] | None:
    """The image paths the OME group's "series" lists (None: it lists none)."""
    if not ome_attributes:
        return None
    inner = ome_attributes.get("ome") if isinstance(ome_attributes.get("ome"), dict) else ome_attributes
    series = inner.get("series")
    if series is None:
        return None
    if not (isinstance(series, list) and series and all(isinstance(s, str) for s in series)):
        raise VolumeFileError(path, f"series must be a list of image paths, got {_short(series)}",
                              "OME/series")
    return series


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
