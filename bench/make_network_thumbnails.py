"""The welcome page's thumbnails of the shipped example networks (gui/welcome.py): each
networks/*.json rendered once, headless, at THUMBNAIL_SIZE pixels (its first display processor's
size set to that), written to networks/thumbnails/<name>.png. They ship with the networks, so the
welcome page renders nothing and downloads nothing; a network without one is listed by name.

    .venv/bin/python bench/make_network_thumbnails.py [NAME.json ...]

A network that cannot be rendered here (its data set missing) is reported and skipped, and so is
one with no display processor (volume_*.json convert a file: they only write). About 10 s for all.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
NETWORKS = REPO / "networks"


def render_thumbnail(path: Path, out: Path) -> None:
    import vgraph
    from vgraph.gui.welcome import THUMBNAIL_SIZE
    from vgraph.imagefile import to_uint8
    from vgraph.live.evaluator import is_display
    from vgraph.atomic import atomic_path
    import PIL.Image

    network = vgraph.load(path)
    displays = [p.id for p in network.processors.values() if is_display(type(p))]
    if not displays:
        raise ValueError("no display processor (nothing to show)")
    display = displays[0]
    if "size" in network[display].properties:
        network.set(f"{display}.size", [THUMBNAIL_SIZE, THUMBNAIL_SIZE])
    image = PIL.Image.fromarray(to_uint8(network.evaluate(display)))
    image.thumbnail((THUMBNAIL_SIZE, THUMBNAIL_SIZE))
    with atomic_path(out, suffix=".png") as temporary:
        image.save(temporary, "PNG")


def main(argv=None) -> int:
    names = (argv if argv is not None else sys.argv[1:]) or sorted(p.name for p in NETWORKS.glob("*.json"))
    (NETWORKS / "thumbnails").mkdir(exist_ok=True)
    for name in names:
        path = NETWORKS / name
        start = time.perf_counter()
        try:
            render_thumbnail(path, NETWORKS / "thumbnails" / f"{path.stem}.png")
        except Exception as error:  # noqa: BLE001 - reported, the others still get theirs
            print(f"{name}: skipped: {error}")
            continue
        print(f"{name}: {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
