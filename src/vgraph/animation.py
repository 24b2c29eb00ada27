"""Turntables, parameter sweeps and keyframed timelines as videos: ``vgraph animate`` and ``animate()``.

Every animation is keyframe tracks (vgraph.tracks) played at one time per frame:

- ``orbit``: frame i turns every camera of the network by ``orbit * i / frames`` degrees about its
  own up axis (360 degrees over 120 frames ends at 357 and loops without a repeated frame). That is
  a camera track with a keyframe every 90 degrees or less (Camera.rotate from the camera as it
  was, so nothing drifts), whose slerp between keyframes is exactly the turn about the up axis;
  time is the frame number. Linked cameras get one track per link group: a link carries the value
  to its followers.
- ``over``: frame i sets an integer property to the i-th value (``ID.PROPERTY=START:STOP``, both
  ends included; without a range, 0 .. time_steps - 1 of the volume that processor produces): a
  track with a ``step`` keyframe per frame.
- ``timeline``: the network's own tracks, one frame every 1/fps seconds from 0 to the last keyframe
  (or ``frames`` frames over that span).

Each frame evaluates only what the target needs (network.update), and the properties the tracks
set are put back afterwards. Where the frames go: vgraph.animation_output.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

import vgraph
from vgraph import cli_common, cli_values
from vgraph.animation_output import Output
from vgraph.camera import VIEW_NAMES
from vgraph.cli_common import add_allow_write
from vgraph.cli_values import parse_size, user_path
from vgraph.errors import PropertyError, VGraphError
from vgraph.image import Image
from vgraph.network import Network, split_address
from vgraph.properties import CameraProperty, IntProperty
from vgraph.scheduler import BlankImageWarning, blank_image_warning, default_target
from vgraph.time_series import warn_time_series
from vgraph.tracks import Keyframe, Track, apply_tracks, changed_properties, frame_times
from vgraph.volume import Volume

DEFAULT_FRAMES = 120
DEFAULT_FPS = 30.0
ORBIT_KEY_DEGREES = 90.0   # the largest turn between two orbit keyframes: slerp takes the short way


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
    start_values = {address: network.get(address) for address in changed_properties(plan.tracks, network)}
    bar = tqdm(total=len(plan.times), unit="frame", file=sys.stderr, disable=not progress,
               desc=output.path.name)
    try:
        with output.writer(fps) as write:
            for index in range(len(plan.times)):
                write(render_frame(network, target, plan, index, size), index)
                bar.update()
    finally:
        bar.close()
        for address, value in start_values.items():
            network.set(address, value)
    return len(plan.times)


def render_frame(network: Network, target: str, plan: "FramePlan", index: int, size) -> np.ndarray:
    """Float RGBA (H, W, 4) of frame ``index``: the tracked properties set, evaluated."""
    apply_tracks(network, plan.tracks, plan.times[index])
    network.update(target, size=size)
    image = network.output(target)
    if not isinstance(image, Image):
        raise VGraphError(f"{target} holds {type(image).__name__}, not an image: choose an image "
                          f"port to animate")
    pixels = image.to_numpy()
    if index == 0:  # said once: the first frame stands for the others
        warn_time_series(network, skip=plan.swept)  # animating the time step shows them all
    warning = blank_image_warning(network, target, pixels) if index == 0 else None
    if warning:
        warnings.warn(BlankImageWarning(warning), stacklevel=3)
    return pixels


# --- what each frame shows ------------------------------------------------------------------------
@dataclass(frozen=True)
class FramePlan:
    tracks: tuple[Track, ...]   # what changes (vgraph.tracks) ...
    times: tuple[float, ...]    # ... played at these times, one per frame
    swept: str | None = None    # the integer property ``over`` steps through


def plan_frames(network: Network, orbit, frames, over) -> FramePlan:
    """A turntable and/or a sweep as tracks, checked against the network before anything is
    rendered; time is the frame number."""
    address, values = sweep(network, over) if over is not None else (None, ())
    if frames is None:
        frames = len(values) if values else DEFAULT_FRAMES
    _check_frames(frames)
    if values and frames != len(values):
        raise VGraphError(f"frames is {frames} but {address} takes {len(values)} values "
                          f"({values[0]} .. {values[-1]}): leave frames out or change the range")
    orbit = (0.0 if values else 360.0) if orbit is None else orbit
    _check_number(orbit, "orbit", positive=False)
    tracks = orbit_tracks(network, float(orbit), int(frames))
    if address:
        tracks += (Track(address, tuple(Keyframe(float(i), v, "step") for i, v in enumerate(values))),)
    return FramePlan(tracks, tuple(float(i) for i in range(frames)), address)


def orbit_tracks(network: Network, degrees: float, frames: int) -> tuple[Track, ...]:
    """A turn of ``degrees`` over ``frames`` frames (the last frame one step short of it) as one
    camera track per link group (``camera_leaders``), a keyframe every ORBIT_KEY_DEGREES or less."""
    if degrees == 0.0:
        return ()
    keys = math.ceil(abs(degrees) / ORBIT_KEY_DEGREES)
    turns = [(frames * k / keys, degrees * k / keys) for k in range(keys + 1)]
    tracks = []
    for address in camera_leaders(network):
        camera = network.get(address)
        tracks.append(Track(address, tuple(
            Keyframe(time, camera if angle == 0.0 else camera.rotate(math.radians(angle), 0.0))
            for time, angle in turns)))   # exactly the start at frame 0: rotate() orthonormalises up
    return tuple(tracks)


def plan_timeline(network: Network, orbit, frames, over, fps: float) -> FramePlan:
    """The frames of the network's tracks: every 1/fps seconds, or ``frames`` over their span."""
    if orbit is not None or over is not None:
        raise VGraphError("--timeline plays the network's tracks: leave out --orbit and --over "
                          "(a turntable is a camera track; docs/guide/animation.md)")
    if not network.tracks:
        raise VGraphError("the network has no tracks to play: add keyframes in the GUI's Timeline "
                          "or a \"tracks\" list to the file (docs/guide/animation.md)")
    if frames is not None:
        _check_frames(frames)
    return FramePlan(tuple(network.tracks), tuple(frame_times(network.tracks, fps, frames)))


def _check_frames(frames) -> None:
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
        raise VGraphError(f"frames must be a positive integer, got {frames!r}")


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
