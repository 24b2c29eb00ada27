"""Canvas: the sink the CLI writes and the GUI shows."""

from vgraph import Inport, Processor, VectorProperty
from vgraph.image import Image


class Canvas(Processor):
    """Shows an image; its size is the size the renderers upstream draw at."""

    category = "Output"
    inports = [Inport("image", Image)]
    size = VectorProperty((512, 512), min=1, max=16384, integer=True,
                          doc="width and height in pixels that upstream renderers draw at")

    def process(self, image: Image) -> None:
        """Nothing to compute: the network keeps the image it received (``network.output(id)``)."""
