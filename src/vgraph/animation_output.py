"""Where ``vgraph animate`` writes its frames: ``Output.of(path)`` by name, ``.mp4`` (H.264,
yuv420p, CRF 18, even width and height, streamed into ffmpeg), ``.gif`` (loops for ever; frame
times are whole hundredths of a second), a folder (``frame_0000.png``, ...) or a pattern such as
``frames/turn_{:04d}.png`` (8-bit RGBA PNGs written exactly as ``vgraph run -o`` writes its image).
Videos are written to a temporary file that replaces the target only when the last frame is in
(vgraph.atomic); each PNG is written atomically.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vgraph.atomic import atomic_path, check_output_path
from vgraph.errors import VGraphError
from vgraph.file_names import file_name_problem, shown
from vgraph.imagefile import to_uint8, write_png

VIDEO_EXTENSIONS = (".mp4", ".gif")
MP4_CRF = 18  # x264's constant rate factor: 18 is close to visually lossless, 23 its default
FRAME_NAME = "frame_{:04d}.png"


@dataclass(frozen=True)
class Output:
    path: Path
    kind: str                  # "mp4", "gif" or "png"
    pattern: str | None = None  # PNG sequence: a str.format pattern with one integer field

    @classmethod
    def of(cls, path) -> "Output":
        text = str(path)
        problem = file_name_problem(text)
        if problem is not None:
            raise VGraphError(f"-o {shown(text)}: {problem}")
        suffix = Path(text).suffix.lower()
        if "{" in text:
            if suffix != ".png":
                raise VGraphError(f"{text}: a frame pattern must end in .png, e.g. frames/turn_{{:04d}}.png")
            try:
                text.format(0)
            except (ValueError, IndexError, KeyError) as error:
                raise VGraphError(f"{text}: not a frame pattern with one integer field such as "
                                  f"{{:04d}} ({error})") from None
            return cls(Path(text), "png", text)
        if suffix in VIDEO_EXTENSIONS:
            return cls(Path(text), suffix[1:])
        if not suffix or Path(text).is_dir():
            return cls(Path(text), "png", str(Path(text) / FRAME_NAME))
        raise VGraphError(f"{text}: cannot write '{suffix}' animations; use .mp4, .gif, a folder or "
                          f"a pattern such as frames/turn_{{:04d}}.png")

    def check(self, size=None) -> None:
        """Refuse an unwritable target (and odd MP4 sizes) before anything is rendered."""
        if self.kind == "png":
            check_output_path(self.pattern.format(0), create_folder=True)
        else:
            check_output_path(self.path)
        if self.kind == "mp4" and size is not None:
            _check_even(size)

    def writer(self, fps: float):
        """A context manager giving ``write(rgba_float, index)``."""
        if self.kind == "png":
            return _PngSequence(self.pattern)
        return _Video(self.path, self.kind, fps)


def _check_even(size) -> None:
    width, height = size
    if width % 2 or height % 2:
        raise VGraphError(f"an MP4 (H.264, yuv420p) needs an even width and height, got "
                          f"{width}x{height}: choose another size")


class _PngSequence:
    def __init__(self, pattern: str):
        self.pattern = pattern

    def __enter__(self):
        return lambda pixels, index: write_png(self.pattern.format(index), pixels)

    def __exit__(self, *exc):
        return False


class _Video:
    """MP4 frames stream into ffmpeg; GIF frames are kept and written at the end (Pillow writes a
    GIF in one go). Either way into a temporary file that replaces the target at the end."""

    def __init__(self, path: Path, kind: str, fps: float):
        self.path, self.kind, self.fps = path, kind, fps
        self.size = None

    def __enter__(self):
        self._atomic = atomic_path(self.path, suffix="." + self.kind)
        self.temporary = self._atomic.__enter__()
        self.frames = []
        self.stream = None
        return self.write

    def write(self, pixels: np.ndarray, index: int) -> None:
        size = (pixels.shape[1], pixels.shape[0])
        if self.size is None:
            self.size = size
            if self.kind == "mp4":
                _check_even(size)
        elif size != self.size:
            raise VGraphError(f"frame {index} is {size[0]}x{size[1]} but frame 0 was "
                              f"{self.size[0]}x{self.size[1]}; a video needs one size")
        rgb = opaque_rgb(pixels)
        if self.kind == "gif":
            self.frames.append(rgb)
            return
        if self.stream is None:
            import imageio.v2 as imageio  # imported when a video is written: 8 ms at every command's start
            self.stream = imageio.get_writer(
                self.temporary, format="FFMPEG", fps=self.fps, codec="libx264", quality=None,
                pixelformat="yuv420p", macro_block_size=1, ffmpeg_log_level="error",
                output_params=["-crf", str(MP4_CRF), "-movflags", "+faststart"])
        self.stream.append_data(rgb)

    def __exit__(self, kind, error, traceback):
        try:
            if self.stream is not None:
                self.stream.close()
            if kind is None and self.kind == "gif":
                import imageio.v3 as iio  # imported when a video is written: 8 ms at every command's start
                iio.imwrite(self.temporary, np.stack(self.frames), extension=".gif",
                            duration=1000.0 / self.fps, loop=0)
        except BaseException as failure:
            self._atomic.__exit__(type(failure), failure, failure.__traceback__)
            raise
        return self._atomic.__exit__(kind, error, traceback)


def opaque_rgb(pixels: np.ndarray) -> np.ndarray:
    """uint8 RGB over black: videos have no alpha (renderers' images are opaque anyway)."""
    rgba = to_uint8(pixels).astype(np.uint16)
    return (rgba[..., :3] * rgba[..., 3:] // 255).astype(np.uint8)
