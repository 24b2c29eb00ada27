"""What a file's header says about its voxels being labels (``Volume.holds_labels``), per format.

Only what a file states counts here; a guess from the values themselves (an integer volume with
few distinct values) is vgraph.label_guess's, made after reading. A declaration is:
- NIfTI: ``intent_code`` NIFTI_INTENT_LABEL (1002). A description that merely mentions labels
  is not one (descriptions are free text, e.g. "labelled by the scanner's protocol").
- NRRD: the keys 3D Slicer writes into a segmentation (``Segment0_ID``, ``Segment0_LabelValue``,
  ..., ``Segmentation_MasterRepresentation``), or a ``labelmap`` key / axis kind.
- VTK image data (.vti): the rendered point-data array's name, or a FieldData array's name,
  says so (``label``, ``labels``, ``tissue``, ``segment``, ``segmentation``: "tissue labels",
  "SegmentationLabels"); names like "density" or "Scalars_" are intensities.
"""

from __future__ import annotations

import re

NIFTI_INTENT_LABEL = 1002  # nifti1.h: "the value at each voxel is an index into some set of labels"
_LABEL_NAME = re.compile(r"label|tissue|segment", re.IGNORECASE)
_SLICER_SEGMENTATION_KEY = re.compile(r"^(Segment\d+_|Segmentation_)")


def name_says_labels(name: str | None) -> bool:
    """Whether an array's name says it holds labels ("tissue labels", "segmentation")."""
    return bool(name) and _LABEL_NAME.search(name) is not None


def vti_says_labels(image, array) -> bool:
    """A VTI's ImageData element declares labels by the name of the point-data ``array`` read, or
    by the name of an array of its FieldData."""
    fields = image.findall("FieldData/DataArray") + image.findall("Piece/FieldData/DataArray")
    return name_says_labels(array.get("Name")) or any(name_says_labels(a.get("Name")) for a in fields)


def nifti_says_labels(header) -> bool:
    """A nibabel NIfTI header declares labels by its intent code alone."""
    try:
        return int(header["intent_code"]) == NIFTI_INTENT_LABEL
    except (KeyError, TypeError, ValueError):
        return False


def nrrd_says_labels(header: dict) -> bool:
    """A pynrrd header dict declares labels by Slicer's segmentation keys or a labelmap key/kind."""
    kinds = header.get("kinds")
    kinds = [str(kind).lower() for kind in kinds] if isinstance(kinds, (list, tuple)) else []
    return ("labelmap" in kinds or any(str(key).lower() == "labelmap" for key in header)
            or any(_SLICER_SEGMENTATION_KEY.match(str(key)) for key in header))
