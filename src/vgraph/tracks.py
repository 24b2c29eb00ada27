"""Keyframe tracks: any property of a network animated over time (``vgraph animate --timeline``,
the GUI's timeline dock).

A network file may hold ``"tracks"``: each names a property by its address and lists keyframes,

    {"property": "rc.camera", "keyframes": [
        {"time": 0.0, "value": {...}, "easing": "linear"},
        {"time": 4.0, "value": {...}}]}

``property`` is ``id.property``, or ``id.property.field`` for one field of a camera or a transfer
function (``rc.transfer_function.tf_shift``; vgraph.track_targets), ``time`` in seconds (from 0,
strictly increasing within a track), ``value`` in the property's (or field's) JSON
form (as under "properties"), ``easing`` how the segment from this keyframe to the next runs:
``linear``, ``ease-in-out`` (smoothstep, 3u^2 - 2u^3: starts and stops at rest) or ``step`` (this
value holds until the next keyframe). Before the first keyframe the first value holds, after the
last the last; at a keyframe's time the value is exactly the keyframe's.

Between two keyframes the value is interpolated by the property's kind (``INTERPOLATORS``):

- cameras on the sphere: the orientation (right, up, back) is slerped (scipy's Slerp, the shortest
  turn), the distance to the focus, the focus, fov and parallel scale linearly, and the eye is put
  back at focus + back * distance, so a camera orbits its focus instead of cutting through it;
  projection, clipping planes given by hand and fit_to_data step;
- transfer functions point by point: two keyframes' TFs must have the same space and the same
  number of points (each point's position, colour and opacity move linearly; positions stay in
  order because both lists are), and tf_shift / tf_scale move linearly; otherwise the track is
  refused, naming the two keyframes;
- clip planes plane by plane (the same number in both keyframes): point linearly, the unit normal
  slerped;
- numbers, vectors and colours linearly (integers rounded);
- everything else (options, booleans, strings, files, label tables, markups) stepwise.

A track whose processor or property does not exist, whose keyframes are out of order, or whose
value the property refuses is refused when the file is read, as a NetworkFileError naming the
file and the JSON path (``tracks[1].keyframes[2].value``).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from scipy.spatial.transform import Rotation, Slerp

from vgraph.camera import Camera
from vgraph.errors import NetworkFileError, VGraphError
from vgraph.network import Network
from vgraph.properties import Property
from vgraph.track_targets import target_of
from vgraph.transfer_function import TransferFunction

EASINGS = ("linear", "ease-in-out", "step")
MAX_SECONDS = 86400.0    # a keyframe's time: a day is longer than any film made of a network
MAX_FRAMES = 1_000_000   # a timeline's frames: 9 hours at 30 fps; more is a typo, not a film
Easing = Literal["linear", "ease-in-out", "step"]


class TrackError(VGraphError):
    """A track that cannot be animated (two transfer functions that cannot be matched, ...)."""


# --- the file's form ------------------------------------------------------------------------------
class KeyframeEntry(BaseModel):
    model_config = ConfigDict(extra="forbid")

    time: float = Field(ge=0.0, le=MAX_SECONDS, allow_inf_nan=False)
    value: Any
    easing: Easing = "linear"


class TrackEntry(BaseModel):
    model_config = ConfigDict(extra="forbid")

    property: str
    keyframes: list[KeyframeEntry] = Field(min_length=1)


# --- the model ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Keyframe:
    time: float
    value: Any             # as the property stores it (a Camera, a TransferFunction, a float ...)
    easing: str = "linear"


@dataclass(frozen=True)
class Track:
    address: str           # "processor_id.property"
    keyframes: tuple[Keyframe, ...]

    @property
    def end(self) -> float:
        return self.keyframes[-1].time

    def with_keyframe(self, keyframe: Keyframe) -> "Track":
        """This track with ``keyframe`` added, replacing one at the same time."""
        kept = [k for k in self.keyframes if k.time != keyframe.time]
        return Track(self.address, tuple(sorted([*kept, keyframe], key=lambda k: k.time)))

    def without_keyframe(self, time: float) -> "Track":
        return Track(self.address, tuple(k for k in self.keyframes if k.time != time))


def duration(tracks) -> float:
    """The time of the last keyframe of all tracks (0 without tracks)."""
    return max((track.end for track in tracks), default=0.0)


def frame_times(tracks, fps: float, frames: int | None = None) -> list[float]:
    """The times of the frames: every 1/fps seconds from 0 to the end (the last keyframe's time
    included), or ``frames`` times spread evenly over the same span."""
    end = duration(tracks)
    if frames is None:
        count = math.floor(end * fps + 1e-9) + 1
        if count > MAX_FRAMES:
            raise VGraphError(f"{end:g} s at {fps:g} frames per second are {count} frames, more than "
                              f"{MAX_FRAMES}: lower the fps or give the number of frames")
        return [index / fps for index in range(count)]
    if frames > MAX_FRAMES:
        raise VGraphError(f"{frames} frames are more than a timeline plays ({MAX_FRAMES})")
    if frames == 1:
        return [0.0]
    return [end * index / (frames - 1) for index in range(frames)]


# --- reading and writing --------------------------------------------------------------------------
def tracks_from_json(entries, network: Network, file: str = "<network>", base_dir=None) -> tuple[Track, ...]:
    """Tracks from the file's ``tracks`` list, checked against ``network``; every problem is
    collected into one NetworkFileError (JSON path, reason)."""
    problems: list[tuple[str, str]] = []
    tracks = []
    for index, entry in enumerate(entries):
        where = f"tracks[{index}]"
        try:
            entry = entry if isinstance(entry, TrackEntry) else TrackEntry.model_validate(entry)
        except ValidationError as error:
            problems.extend((_json_path(where, e["loc"]), e["msg"]) for e in error.errors())
            continue
        track = _track(entry, network, where, problems, base_dir)
        if track is not None:
            tracks.append(track)
    if problems:
        raise NetworkFileError(file, problems)
    return tuple(tracks)


def make_track(network: Network, address: str, keyframes) -> Track:
    """A checked track from Python: ``keyframes`` as (time, value) or (time, value, easing) tuples
    or dicts as in the file; values in any form the property takes (a Camera, a preset's name ...).
    NetworkFileError (file "<python>") as for a file's track."""
    entries = [k if isinstance(k, dict) else dict(zip(("time", "value", "easing"), k)) for k in keyframes]
    (track,) = tracks_from_json([{"property": address, "keyframes": entries}], network, "<python>",
                                network.base_dir)
    return track


def _track(entry: TrackEntry, network: Network, where: str, problems: list, base_dir) -> Track | None:
    try:
        target = target_of(network, entry.property)
    except VGraphError as error:
        problems.append((f"{where}.property", getattr(error, "reason", str(error))))
        return None
    keyframes, before = [], len(problems)
    for number, key in enumerate(entry.keyframes):
        if number and key.time <= entry.keyframes[number - 1].time:
            problems.append((f"{where}.keyframes[{number}].time",
                             f"keyframes must be in order of time, each later than the one before: "
                             f"{key.time:g} comes after {entry.keyframes[number - 1].time:g}"))
        try:
            value = target.validate(key.value, base_dir)
        except VGraphError as error:
            problems.append((f"{where}.keyframes[{number}].value", getattr(error, "reason", str(error))))
            continue
        keyframes.append(Keyframe(key.time, value, key.easing))
    if len(problems) > before:
        return None
    track = Track(entry.property, tuple(keyframes))
    try:
        check_track(track, target)
    except TrackError as error:
        problems.append((f"{where}.keyframes", str(error)))
        return None
    return track


def _json_path(where: str, location) -> str:
    return where + "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in location)


def property_of(network: Network, address: str) -> Property:
    """The property a track of ``address`` sets (its field's, for ``id.property.field``)."""
    return network._property(target_of(network, address).address)


def tracks_to_json(network: Network, tracks) -> list[dict]:
    """The file's form of ``tracks``. A track whose processor (or property) is gone is left out, as
    the links of a removed processor go with it: a file naming it could not be read again. The
    network keeps it, so undoing the removal brings it back."""
    out = []
    for track in tracks:
        try:
            target = target_of(network, track.address)
        except VGraphError:
            continue
        out.append({"property": track.address,
                    "keyframes": [{"time": k.time, "value": target.to_json(k.value), "easing": k.easing}
                                  for k in track.keyframes]})
    return out


# --- evaluation -----------------------------------------------------------------------------------
def apply_tracks(network: Network, tracks, time: float) -> None:
    """Set every tracked property to its value at ``time``."""
    for track in tracks:
        target = target_of(network, track.address)
        target.set(network, value_at(track, target, time))


def changed_properties(tracks, network: Network) -> list[str]:
    """The properties (``id.property``) that playing ``tracks`` sets, each once, to put back after."""
    return list(dict.fromkeys(target_of(network, track.address).address for track in tracks))


def value_at(track: Track, prop: Property, time: float):
    keys = track.keyframes
    if time <= keys[0].time:
        return keys[0].value
    if time >= keys[-1].time:
        return keys[-1].value
    index = bisect.bisect_right(keys, time, key=lambda k: k.time) - 1  # the last at or before
    start, stop = keys[index], keys[index + 1]
    if time == start.time:
        return start.value
    u = eased((time - start.time) / (stop.time - start.time), start.easing)
    if u == 0.0:
        return start.value
    return INTERPOLATORS.get(prop.kind, _step)(start.value, stop.value, u, prop)


def eased(u: float, easing: str) -> float:
    if easing == "step":
        return 0.0
    if easing == "ease-in-out":
        return u * u * (3.0 - 2.0 * u)
    return u


def check_track(track: Track, prop: Property) -> None:
    """Refuse, naming the keyframes, what cannot be interpolated (TrackError)."""
    check = CHECKS.get(prop.kind)
    for number in range(len(track.keyframes) - 1):
        start, stop = track.keyframes[number], track.keyframes[number + 1]
        reason = check(start.value, stop.value) if check and start.easing != "step" else None
        if reason:
            raise TrackError(f"keyframes {number} and {number + 1} of {track.address} cannot be "
                             f"interpolated: {reason}")


def _lerp(a, b, u: float):
    return a + (b - a) * u


def _number(a, b, u, prop):
    value = _lerp(a, b, u)
    return int(round(value)) if prop.kind == "int" else value


def _vector(a, b, u, prop):
    if a is None or b is None:
        return a
    values = [_lerp(x, y, u) for x, y in zip(a, b)]
    return tuple(int(round(v)) if getattr(prop, "integer", False) else v for v in values)


def _step(a, b, u, prop):
    return a


def _camera(a: Camera, b: Camera, u: float, prop) -> Camera:
    orientation = Slerp([0.0, 1.0], Rotation.from_matrix([_orientation(a), _orientation(b)]))([u])
    matrix = orientation.as_matrix()[0]
    focus = _lerp(np.asarray(a.focus), np.asarray(b.focus), u)
    position = focus + matrix[:, 2] * _lerp(a.distance, b.distance, u)
    near_far = {}
    if None not in (a.near, a.far, b.near, b.far):
        near_far = {"near": _lerp(a.near, b.near, u), "far": _lerp(a.far, b.far, u)}
    changes = dict(position=_vec3(position), focus=_vec3(focus), up=_vec3(matrix[:, 1]),
                   fov=_lerp(a.fov, b.fov, u), parallel_scale=_lerp(a.parallel_scale, b.parallel_scale, u))
    return Camera(**{**a.model_dump(), **changes, **near_far})  # validated, as every camera


def _orientation(camera: Camera) -> np.ndarray:
    """The rotation whose columns are the camera's right, up and back (towards the eye)."""
    right, up, forward = camera.basis()
    return np.column_stack([right, up, -forward])


def _vec3(array) -> tuple[float, float, float]:
    return tuple(float(v) for v in array)


def _transfer_function(a: TransferFunction, b: TransferFunction, u, prop) -> TransferFunction:
    points = [tuple(float(_lerp(x, y, u)) for x, y in zip(p, q)) for p, q in zip(a.points, b.points)]
    return TransferFunction(space=a.space, points=points, tf_shift=_lerp(a.tf_shift, b.tf_shift, u),
                            tf_scale=_lerp(a.tf_scale, b.tf_scale, u))


def _tf_mismatch(a: TransferFunction, b: TransferFunction) -> str | None:
    if a.space != b.space:
        return (f"the transfer functions have positions in different spaces ({a.space} and "
                f"{b.space}); give both in one space")
    if len(a.points) != len(b.points):
        return (f"the transfer functions have {len(a.points)} and {len(b.points)} points; a transfer "
                f"function animates point by point, so give both the same number of points")
    return None


def _clip_planes(a, b, u, prop):
    return tuple(_plane(p, q, u) for p, q in zip(a, b))


def _plane(p, q, u):
    normal = Slerp([0.0, 1.0], _normal_turn(p.unit_normal(), q.unit_normal()))([u]).apply(p.unit_normal())[0]
    point = _lerp(np.asarray(p.point), np.asarray(q.point), u)
    return p.model_copy(update={"normal": _vec3(normal), "point": _vec3(point)})


def _normal_turn(n0: np.ndarray, n1: np.ndarray) -> Rotation:
    """The identity and the shortest rotation taking n0 to n1 (the Slerp between them)."""
    turn, _ = Rotation.align_vectors([n1], [n0])
    return Rotation.concatenate([Rotation.identity(), turn])


def _planes_mismatch(a, b) -> str | None:
    if len(a) != len(b):
        return (f"{len(a)} and {len(b)} clip planes; planes animate one by one, so give both "
                f"keyframes the same number")
    for index, (p, q) in enumerate(zip(a, b)):
        if float(p.unit_normal() @ q.unit_normal()) < -1.0 + 1e-9:
            return (f"plane {index}'s normals are opposite, so no turn between them is the "
                    f"shortest; add a keyframe in between")
    return None


INTERPOLATORS = {"float": _number, "int": _number, "vector": _vector, "color": _vector,
                 "camera": _camera, "transfer_function": _transfer_function,
                 "clip_planes": _clip_planes}
CHECKS = {"transfer_function": _tf_mismatch, "clip_planes": _planes_mismatch}


# --- editing --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SetTracks:
    """An edit in vgraph.edits's vocabulary (apply, inverse, describe), so the GUI's undo stack
    takes it: the network's tracks replaced by ``tracks`` (``old``: what they were)."""

    tracks: tuple
    old: tuple
    text: str = "Edit keyframes"

    @classmethod
    def of(cls, network: Network, tracks, text: str = "Edit keyframes") -> "SetTracks":
        return cls(tuple(tracks), tuple(network.tracks), text)

    def describe(self) -> str:
        return self.text

    def apply(self, network: Network) -> None:
        for track in self.tracks:
            target_of(network, track.address)  # refuse a track of a processor that is gone
        network.tracks = tuple(self.tracks)

    def inverse(self) -> "SetTracks":
        return SetTracks(self.old, self.tracks, self.text)


def with_keyframe(tracks, address: str, keyframe: Keyframe) -> tuple[Track, ...]:
    """``tracks`` with ``keyframe`` added to the track of ``address`` (a new track if none)."""
    for index, track in enumerate(tracks):
        if track.address == address:
            return (*tracks[:index], track.with_keyframe(keyframe), *tracks[index + 1:])
    return (*tracks, Track(address, (keyframe,)))


def without_keyframe(tracks, address: str, time: float) -> tuple[Track, ...]:
    """``tracks`` less the keyframe of ``address`` at ``time`` (a track left empty goes)."""
    changed = (track.without_keyframe(time) if track.address == address else track for track in tracks)
    return tuple(track for track in changed if track.keyframes)
