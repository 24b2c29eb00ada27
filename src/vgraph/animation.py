"""Turntables, parameter sweeps and keyframed timelines as videos: ``vgraph animate`` and ``animate()``.

Frame i turns every camera of the network by ``orbit * i / frames`` degrees about its own up axis
(Camera.rotate from the camera as it was, so nothing drifts; 360 degrees over 120 frames ends at
357 and loops without a repeated frame), and/or sets an integer property to the i-th value of
``over`` (``ID.PROPERTY=START:STOP``, both ends included; without a range, 0 .. time_steps - 1 of
the volume that processor produces). Linked cameras are set once per link group: a link carries the
value to its followers. With ``timeline`` the network's keyframe tracks (vgraph.tracks) set every
tracked property instead, one frame every 1/fps seconds from 0 to the last keyframe (or ``frames``
frames over that span). Each frame evaluates only what the target needs (network.update), and the
network's cameras and the swept or tracked properties are put back afterwards.

Outputs by name: ``.mp4`` (H.264, yuv420p, CRF 18, even width and height), ``.gif`` (loops for
ever; frame times are whole hundredths of a second), a folder (``frame_0000.png``, ...) or a
pattern such as ``frames/turn_{:04d}.png``: 8-bit RGBA PNGs written exactly as ``vgraph run -o``
writes its image. Videos are written to a temporary file that replaces the target only when the
last frame is in (vgraph.atomic); each PNG is written atomically.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

import vgraph
from vgraph import cli_common, cli_values
from vgraph.atomic import atomic_path, check_output_path
from vgraph.camera import VIEW_NAMES
from vgraph.cli_common import add_allow_write
from vgraph.cli_values import parse_size, user_path
from vgraph.errors import PropertyError, VGraphError
from vgraph.file_names import file_name_problem, shown
from vgraph.image import Image
from vgraph.imagefile import to_uint8, write_png
from vgraph.network import Network, split_address
from vgraph.properties import CameraProperty, IntProperty
from vgraph.scheduler import BlankImageWarning, blank_image_warning, default_target
from vgraph.time_series import warn_time_series
from vgraph.tracks import apply_tracks, frame_times
from vgraph.volume import Volume

VIDEO_EXTENSIONS = (".mp4", ".gif")
DEFAULT_FRAMES = 120
DEFAULT_FPS = 30.0
MP4_CRF = 18  # x264's constant rate factor: 18 is close to visually lossless, 23 its default
FRAME_NAME = "frame_{:04d}.png"


# --- the Python API -------------------------------------------------------------------------------
def animate(network: Network, path, orbit: float | None = None, frames: int | None = None,
            over=None, fps: float = DEFAULT_FPS, size: tuple[int, int] | None = None,
            target: str | None = None, progress: bool = False, timeline: bool = False) -> int:
    """Render frames of ``target`` (default: the Canvas) into ``path`` and return how many.

    ``orbit``: degrees the cameras turn over all frames (default 360, or 0 when ``over`` is given).
    ``over``: "ID.PROPERTY", "ID.PROPERTY=START:STOP" or (address, values) for an integer property.
    ``frames``: default the number of ``over`` values, else 120. ``size``: (width, height).
    ``timeline``: play the network's keyframe tracks instead (one frame every 1/fps seconds)."""
    _check_number(fps, "fps")
    plan = plan_timeline(network, orbit, frames, over, fps) if timeline else \
        plan_frames(network, orbit, frames, over)
    output = Output.of(path)
    output.check(size)
    target = target or default_target(network)
    cameras = CameraOrbit(network)
    start_values = {address: network.get(address) for address in plan.changed}
    bar = tqdm(total=plan.frames, unit="frame", file=sys.stderr, disable=not progress,
               desc=output.path.name)
    try:
        with output.writer(fps) as write:
            for index in range(plan.frames):
                write(render_frame(network, target, plan, index, cameras, size), index)
                bar.update()
    finally:
        bar.close()
        cameras.restore()
        for address, value in start_values.items():
            network.set(address, value)
    return plan.frames


def render_frame(network: Network, target: str, plan: "FramePlan", index: int,
                 cameras: "CameraOrbit", size) -> np.ndarray:
    """Float RGBA (H, W, 4) of frame ``index``: the cameras turned, the property set, evaluated."""
    cameras.turn(plan.orbit * index / plan.frames)
    if plan.address:
        network.set(plan.address, plan.values[index])
    if plan.tracks:
        apply_tracks(network, plan.tracks, plan.times[index])
    network.update(target, size=size)
    image = network.output(target)
    if not isinstance(image, Image):
        raise VGraphError(f"{target} holds {type(image).__name__}, not an image: choose an image "
                          f"port to animate")
    pixels = image.to_numpy()
    if index == 0:  # said once: the first frame stands for the others
        warn_time_series(network, skip=plan.address)  # animating the time step shows them all
    warning = blank_image_warning(network, target, pixels) if index == 0 else None
    if warning:
        warnings.warn(BlankImageWarning(warning), stacklevel=3)
    return pixels


# --- what each frame shows ------------------------------------------------------------------------
@dataclass(frozen=True)
class FramePlan:
    frames: int
    orbit: float                # degrees over all frames
    address: str | None = None  # the swept integer property
    values: tuple[int, ...] = ()
    tracks: tuple = ()          # keyframe tracks (vgraph.tracks), played at ``times`` (seconds)
    times: tuple[float, ...] = ()

    @property
    def changed(self) -> list[str]:
        """The properties the frames set, to be put back afterwards."""
        return ([self.address] if self.address else []) + [track.address for track in self.tracks]


def plan_frames(network: Network, orbit, frames, over) -> FramePlan:
    """Check the request against the network before anything is rendered."""
    address, values = sweep(network, over) if over is not None else (None, ())
    if frames is None:
        frames = len(values) if values else DEFAULT_FRAMES
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
        raise VGraphError(f"frames must be a positive integer, got {frames!r}")
    if values and frames != len(values):
        raise VGraphError(f"frames is {frames} but {address} takes {len(values)} values "
                          f"({values[0]} .. {values[-1]}): leave frames out or change the range")
    orbit = (0.0 if values else 360.0) if orbit is None else orbit
    _check_number(orbit, "orbit", positive=False)
    return FramePlan(int(frames), float(orbit), address, tuple(values))


def plan_timeline(network: Network, orbit, frames, over, fps: float) -> FramePlan:
    """The frames of the network's tracks: every 1/fps seconds, or ``frames`` over their span."""
    if orbit is not None or over is not None:
        raise VGraphError("--timeline plays the network's tracks: leave out --orbit and --over "
                          "(a turntable is a camera track; docs/guide/animation.md)")
    if not network.tracks:
        raise VGraphError("the network has no tracks to play: add keyframes in the GUI's Timeline "
                          "or a \"tracks\" list to the file (docs/general/network-format.md)")
    if frames is not None and (isinstance(frames, bool) or not isinstance(frames, (int, np.integer))
                               or frames < 1):
        raise VGraphError(f"frames must be a positive integer, got {frames!r}")
    times = frame_times(network.tracks, fps, frames)
    return FramePlan(len(times), 0.0, tracks=tuple(network.tracks), times=tuple(times))


def sweep(network: Network, over) -> tuple[str, list[int]]:
    """(address, values) of ``over``: "ID.PROPERTY", "ID.PROPERTY=START:STOP" or (address, values)."""
    if isinstance(over, str):
        address, equals, bounds = over.partition("=")
        address = address.strip()
    else:
        address, bounds, equals = over[0], None, ""
    prop = network._property(address)  # names the processor's properties if unknown
    if not isinstance(prop, IntProperty):
        raise PropertyError(address, f"is a {prop.kind} property; only integer properties can be "
                                     f"animated over (and cameras with orbit)")
    if not isinstance(over, str):
        values = [int(v) for v in over[1]]
    elif equals:
        values = _parse_range(over, bounds)
    else:
        values = _default_values(network, address, prop)
    if not values:
        raise VGraphError(f"{over!r}: no values to animate over")
    for value in values:  # refuse an out-of-range value now, not after minutes of rendering
        prop.validate(value, address)
    return address, values


def _parse_range(text: str, bounds: str) -> list[int]:
    try:
        start, stop = (int(v) for v in bounds.split(":"))
    except ValueError:
        raise VGraphError(f"over {text!r}: expected ID.PROPERTY or ID.PROPERTY=START:STOP with "
                          f"integers, e.g. source.time_step=0:9") from None
    step = 1 if stop >= start else -1
    return list(range(start, stop + step, step))  # both ends included


def _default_values(network: Network, address: str, prop: IntProperty) -> list[int]:
    """0 .. time_steps - 1 of the volume the processor makes, else the property's declared range."""
    processor_id, _ = split_address(address, "property")
    processor = network[processor_id]
    volume_ports = [p.name for p in processor.outports if issubclass(p.data_type, Volume)]
    if volume_ports:
        network.update(f"{processor_id}.{volume_ports[0]}")
        steps = getattr(processor.outputs.get(volume_ports[0]), "time_steps", 1)
        if steps > 1:
            return list(range(steps))
        raise VGraphError(f"{address}: the volume of {processor_id} has one time step; give a range "
                          f"as {address}=START:STOP")
    if prop.min is not None and prop.max is not None:
        return list(range(prop.min, prop.max + 1))
    raise VGraphError(f"{address}: no range known; give one as {address}=START:STOP")


def _check_number(value, name: str, positive: bool = True) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
            or not math.isfinite(value) or (positive and value <= 0):
        kind = "a positive number" if positive else "a finite number"
        raise VGraphError(f"{name} must be {kind}, got {value!r}")


# --- cameras --------------------------------------------------------------------------------------
class CameraOrbit:
    """Turns the network's cameras about their up axes, each link group once, always from the
    cameras as they were when created (no drift); ``restore()`` puts them back."""

    def __init__(self, network: Network):
        self.network = network
        self.leaders = camera_leaders(network)
        self.start = {address: network.get(address) for address in self.leaders}

    def turn(self, azimuth: float, elevation: float = 0.0) -> None:
        """Azimuth about each camera's up axis, then elevation about its right axis, in degrees
        (Camera.rotate: positive azimuth turns the scene as a drag to the right does)."""
        for address, camera in self.start.items():
            if azimuth == 0.0 and elevation == 0.0:  # exactly the start: rotate() would
                self.network.set(address, camera)    # orthonormalise up (frame 0 = vgraph run)
            else:
                self.network.set(address, camera.rotate(math.radians(azimuth), math.radians(elevation)))

    def restore(self) -> None:
        for address, camera in self.start.items():
            self.network.set(address, camera)


def camera_leaders(network: Network) -> list[str]:
    """The camera properties to set so that every camera turns exactly once: links carry a value
    from source to target (and back if bidirectional), so a camera that a set one reaches through
    links is left to the link. Cameras nothing links to come first."""
    cameras = [f"{pid}.{name}" for pid, processor in network.processors.items()
               for name, prop in processor.properties.items() if isinstance(prop, CameraProperty)]
    follows = {address: set() for address in cameras}
    for link in network.links:
        if link.source in follows and link.target in follows:
            follows[link.source].add(link.target)
            if link.bidirectional:
                follows[link.target].add(link.source)
    followed = {target for targets in follows.values() for target in targets}
    order = [c for c in cameras if c not in followed] + [c for c in cameras if c in followed]
    leaders, covered = [], set()
    for address in order:
        if address in covered:
            continue
        leaders.append(address)
        pending = [address]
        while pending:
            current = pending.pop()
            if current not in covered:
                covered.add(current)
                pending.extend(follows[current])
    return leaders


# --- outputs --------------------------------------------------------------------------------------
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


# --- the command ----------------------------------------------------------------------------------
def add_parser(commands) -> argparse.ArgumentParser:
    """Add ``vgraph animate`` to the subparsers of vgraph.cli.build_parser."""
    parser = commands.add_parser(
        "animate", help="render a turntable, a sweep over a property or the network's keyframe "
                        "timeline as MP4, GIF or PNG frames",
        description="Render frames of a network: the cameras orbit and/or an integer property "
                    "steps through values, or (--timeline) the network's keyframe tracks play. "
                    "Output by name: .mp4, .gif, a folder or a pattern such as "
                    "frames/turn_{:04d}.png (docs/guide/outputs.md).")
    parser.add_argument("network", type=user_path, help="the .json network")
    parser.add_argument("-o", "--output", required=True,
                        help="turn.mp4, turn.gif, a folder, or a pattern like frames/turn_{:04d}.png")
    parser.add_argument("--orbit", type=float, metavar="DEGREES",
                        help="turn the cameras this far over all frames (default 360, or 0 with --over)")
    parser.add_argument("--frames", type=int,
                        help=f"number of frames (default: one per --over value, else {DEFAULT_FRAMES})")
    parser.add_argument("--over", metavar="ID.PROPERTY[=START:STOP]",
                        help="step an integer property, START and STOP included (default range: "
                             "the volume's time steps)")
    parser.add_argument("--timeline", action="store_true",
                        help="play the network's keyframe tracks, one frame every 1/fps seconds "
                             "(with --frames: that many frames over the tracks' span)")
    parser.add_argument("--fps", type=float, default=DEFAULT_FPS, help="frames per second (default 30)")
    parser.add_argument("--size", type=parse_size, help="image size WxH (default: the Canvas size)")
    parser.add_argument("--port", help="the image port to animate, ID.PORT (default: the Canvas)")
    parser.add_argument("--view", choices=VIEW_NAMES, metavar="NAME",
                        help=f"start from a named view framing the data: {', '.join(VIEW_NAMES)}")
    parser.add_argument("--set", action="append", default=[], metavar="ID.PROPERTY=VALUE",
                        help="change a property first; VALUE is JSON where it parses")
    parser.add_argument("--plugin", action="append", metavar="MODULE", help="import a plug-in module")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_allow_write(parser)
    parser.set_defaults(command=command_animate)
    return parser


def command_animate(args) -> int:
    Output.of(args.output).check(args.size)  # refuse before a long evaluation, not after
    network = vgraph.load(args.network, allow_write=args.allow_write)
    if args.view:
        cli_values.set_view(network, args.view)  # then --set, in vgraph run's order
    for assignment in args.set:
        cli_values.set_from_command_line(network, assignment)  # as vgraph run: paths from the current folder
    cli_common.check_before_evaluating(network, args.network)
    # A blank first frame warns (BlankImageWarning); vgraph.cli.main prints it as one line.
    count = animate(network, args.output, orbit=args.orbit, frames=args.frames, over=args.over,
                    fps=args.fps, size=args.size, target=args.port, progress=not args.quiet,
                    timeline=args.timeline)
    print(f"wrote {count} frames to {args.output}", file=sys.stderr)
    return cli_common.EXIT_OK
