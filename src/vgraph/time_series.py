"""Saying that a volume is one time point of several (a 4D NIfTI, a NRRD with a time axis, an
OME-Zarr with a t axis): a picture of t = 0 looks like the whole file unless someone says so.

A processor with a ``time_step`` property (VolumeSource) whose volume output carries
``time_steps`` > 1 is noted: ``vgraph run`` prints one TimeSeriesWarning line per such processor
(``vgraph: warning: source shows t = 0 of 12 time points of scan.nii.gz; choose another with
source.time_step (0 .. 11)``), ``vgraph animate`` with its first frame unless it animates that
very property, and the GUI adds the note to the processor's status (the inspector's data line).
"""

from __future__ import annotations

import warnings

from vgraph.errors import VGraphWarning


class TimeSeriesWarning(VGraphWarning):
    """A volume of a file with several time points is shown at one of them."""


def time_point_note(processor) -> str | None:
    """``t = 0 of 12 time points; choose with source.time_step (0 .. 11)`` for a processor with a
    ``time_step`` property whose volume output is one of several time points; else None."""
    if "time_step" not in processor.properties:
        return None
    counts = [getattr(data, "time_steps", 1) for data in processor.outputs.values()]
    count = max(counts, default=1)
    if count <= 1:
        return None
    return (f"t = {processor.property_values['time_step']} of {count} time points; choose with "
            f"{processor.id}.time_step (0 .. {count - 1})")


def time_series_notes(network, skip: str | None = None) -> list[str]:
    """One line per processor of ``network`` that shows one time point of several (evaluated
    ones only: their outputs say), naming the file; ``skip``: a property address ("ID.time_step")
    not to note (an animation over it shows every time point)."""
    notes = []
    for processor in network.processors.values():
        note = time_point_note(processor)
        if note is None or skip == f"{processor.id}.time_step":
            continue
        sources = {getattr(data, "source", "") for data in processor.outputs.values()} - {""}
        of = f" of {', '.join(sorted(sources))}" if sources else ""
        notes.append(f"{processor.id} shows {note.replace('time points;', f'time points{of};', 1)}")
    return notes


def warn_time_series(network, skip: str | None = None) -> None:
    """A TimeSeriesWarning for each of ``time_series_notes`` (the CLI prints each as one line)."""
    for note in time_series_notes(network, skip):
        warnings.warn(TimeSeriesWarning(note), stacklevel=2)
