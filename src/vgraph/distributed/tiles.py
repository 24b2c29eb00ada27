"""The tiles split (issue #15): cut the image into a grid of rectangles, render each through the
camera's off-axis sub-frustum (``Camera.tile``), and put the rectangles back together.

- A tile is rendered with a HALO of ``HALO`` pixels on each side that lies inside the image (never
  beyond its edge, where the full image has no pixels either) and cropped back: image passes that
  look at neighbouring pixels (the CurvatureRaycaster's zero-curvature contour reads one pixel each
  way) then see the same neighbours as in the full image.
- Some processors depend on the WHOLE image and cannot be tiled: ``untileable`` names them and why,
  and render() refuses such a network before any task runs (docs/guide/distributed.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import networkx as nx
import numpy as np

from vgraph.errors import VGraphError, positive_pair
from vgraph.image import Image

HALO = 1  # pixels: the widest neighbourhood an image pass of a renderer reads (contour.glsl: 1)


class TileError(VGraphError, ValueError):
    """A tile grid or a network that cannot be rendered as tiles."""


@dataclass(frozen=True)
class Tile:
    """Pixels [x, x + width) x [y, y + height) of the full image (row 0 at the top), rendered as the
    larger rectangle ``rendered`` (x, y, width, height: the tile and its halo inside the image)."""

    x: int
    y: int
    width: int
    height: int
    rendered: tuple[int, int, int, int]

    def crop(self, pixels: np.ndarray) -> np.ndarray:
        """This tile's pixels out of the rendered rectangle's image."""
        x0, y0 = self.x - self.rendered[0], self.y - self.rendered[1]
        return pixels[y0:y0 + self.height, x0:x0 + self.width]


def parse_grid(text: str) -> tuple[int, int]:
    """'CxR' (columns x rows, e.g. '4x2') as (C, R)."""
    try:
        columns, rows = (int(v) for v in str(text).lower().split("x"))
    except ValueError:
        raise TileError(f"tiles must look like COLUMNSxROWS (e.g. 4x2), got '{text}'") from None
    return check_grid((columns, rows))


def check_grid(grid) -> tuple[int, int]:
    return positive_pair(grid, "tiles", "(columns, rows)", TileError)


def cut(size: tuple[int, int], grid: tuple[int, int], halo: int = HALO) -> list[Tile]:
    """The grid's tiles of an image of ``size`` (width, height), row by row from the top left.
    Widths differ by at most one pixel; a grid finer than the image is refused."""
    width, height = size
    columns, rows = check_grid(grid)
    if columns > width or rows > height:
        raise TileError(f"tiles {columns}x{rows} do not fit an image of {width}x{height} pixels")
    xs = [round(i * width / columns) for i in range(columns + 1)]
    ys = [round(j * height / rows) for j in range(rows + 1)]
    tiles = []
    for j in range(rows):
        for i in range(columns):
            x0, x1, y0, y1 = xs[i], xs[i + 1], ys[j], ys[j + 1]
            gx0, gy0 = max(x0 - halo, 0), max(y0 - halo, 0)
            gx1, gy1 = min(x1 + halo, width), min(y1 + halo, height)
            tiles.append(Tile(x0, y0, x1 - x0, y1 - y0, (gx0, gy0, gx1 - gx0, gy1 - gy0)))
    return tiles


def assemble(size: tuple[int, int], tiles: list[Tile], pixels: list[np.ndarray]) -> np.ndarray:
    """The full image (H, W, C) from each tile's rendered rectangle."""
    width, height = size
    image = None
    for tile, rendered in zip(tiles, pixels):
        if image is None:
            image = np.zeros((height, width, rendered.shape[-1]), dtype=rendered.dtype)
        image[tile.y:tile.y + tile.height, tile.x:tile.x + tile.width] = tile.crop(rendered)
    return image


def untileable(network, target: str) -> list[str]:
    """Why the part of ``network`` that ``target`` needs cannot be rendered tile by tile: one line
    per processor that depends on the whole image (empty: it can)."""
    processor_id = target.partition(".")[0]
    needed = {processor_id, *nx.ancestors(network.graph, processor_id)}
    reasons = []
    for pid in sorted(needed):
        processor = network[pid]
        kind = processor.type_name
        if kind == "ColorBar":
            reasons.append(f"ColorBar '{pid}' places its bar in the whole image")
        elif kind == "TextOverlay":
            reasons.append(f"TextOverlay '{pid}' places its caption and scale bar in the whole image")
        elif kind == "Background" and processor.property_values.get("pattern") != "solid":
            reasons.append(f"Background '{pid}': its {processor.property_values.get('pattern')} runs over "
                           "the whole image (a solid background can be tiled)")
        elif kind == "ImageSource":
            reasons.append(f"ImageSource '{pid}' reads a whole image file, not a view through a camera")
        elif kind in ("CurvatureRaycaster", "CurvatureVolumeRaycaster") and \
                processor.property_values.get("normalization") == "linear":
            reasons.append(f"{kind} '{pid}': linear normalization scales by the whole "
                           "image's curvature range (set normalization to exponential)")
        elif _draws_without_a_camera(processor):
            # e.g. a SliceViewer: each tile would be the whole slice squeezed into the tile
            reasons.append(f"{kind} '{pid}' draws its whole picture into any image size (it has no "
                           "camera to take a tile's part of the view from)")
    return reasons


def _draws_without_a_camera(processor) -> bool:
    """Whether the processor makes an image from no image and without a camera."""
    makes_image = any(issubclass(port.data_type, Image) for port in processor.outports)
    reads_image = any(issubclass(port.data_type, Image) for port in processor.inports)
    has_camera = any(prop.kind == "camera" for prop in processor.properties.values())
    return makes_image and not reads_image and not has_camera


def cameras(network) -> dict[str, object]:
    """Every camera property of the network, 'id.name' -> Camera (the full view's)."""
    return {f"{p.id}.{name}": p.property_values[name] for p in network.processors.values()
            for name, prop in p.properties.items() if prop.kind == "camera"}


def set_tile_cameras(network, full_cameras: dict, tile: Tile, size: tuple[int, int]) -> None:
    """Point every camera at ``tile``'s rendered rectangle of the full ``size`` view. The tiled
    values are all computed from the full cameras first and then set: setting the EntryExitPoints
    camera carries the same value along its links (to the RayCaster), and setting that follower
    afterwards is then a no-op, never a tile of a tile."""
    x, y, width, height = tile.rendered
    tiled = {address: camera.tile(x, y, width, height, *size) for address, camera in full_cameras.items()}
    for address, camera in tiled.items():
        network.set(address, camera)
