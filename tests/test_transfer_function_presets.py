"""Transfer-function presets and TF files: exact round trips, errors that name the file and the problem."""

import json

import numpy as np
import pytest

from vgraph.errors import VGraphError
from vgraph.transfer_function import PRESETS, TransferFunction


@pytest.mark.parametrize("name", list(PRESETS))
def test_presets_cover_the_whole_range_and_show_something(name):
    preset = PRESETS[name]
    assert preset.points[0][0] == 0.0 and preset.points[-1][0] == 1.0
    lut = preset.lut()
    assert lut[:, 3].max() > 0.2            # something is visible ...
    assert lut[0, 3] == 0.0                 # ... and the lowest intensities (air, background) are not


def test_ct_presets_make_bone_more_opaque_than_soft_tissue():
    bone, tissue = PRESETS["bone (CT)"], PRESETS["soft tissue (CT)"]
    assert bone(0.3)[3] < tissue(0.3)[3] and bone(0.3)[3] == 0.0   # bone hides the soft tissue range
    assert bone(0.8)[3] > 0.8


@pytest.mark.parametrize("name", list(PRESETS))
def test_save_then_load_is_exact(tmp_path, name):
    path = tmp_path / "tf.json"
    PRESETS[name].save(path)
    assert TransferFunction.load(path) == PRESETS[name]
    assert json.loads(path.read_text()) == {"points": [list(p) for p in PRESETS[name].points]}


def test_save_keeps_floats_exact_and_replaces_the_file(tmp_path):
    path = tmp_path / "tf.json"
    path.write_text("old")
    odd = TransferFunction(points=[(0.1 + 0.2, 1 / 3, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0, np.float64(2 / 7))])
    odd.save(path)
    assert TransferFunction.load(path) == odd
    assert [p.name for p in tmp_path.iterdir()] == ["tf.json"]   # no temporary file left behind


@pytest.mark.parametrize("text, problem", [
    ("{not json", "not valid JSON"),
    ('{"points": []}', "points: List should have at least 1 item"),
    ('{"points": [[0.5, 1, 1, 1]]}', "points: Value error, point 0 needs 5 numbers [position, r, g, b, a]"),
    ('{"points": [[0.5, 1, 1, 1, 1], [0.2, 0, 0, 0, 0]]}', "positions must be non-decreasing"),
    ('{"points": [[0, 0, 0, 0, 0]], "colour": 1}', "colour: Extra inputs are not permitted"),
    ('[[0, 0, 0, 0, 0]]', "not a transfer function"),
])
def test_load_errors_name_the_file_and_the_problem(tmp_path, text, problem):
    path = tmp_path / "broken.json"
    path.write_text(text)
    with pytest.raises(VGraphError) as error:
        TransferFunction.load(path)
    message = str(error.value)
    assert message.startswith(f"{path}: ") and problem in message


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(VGraphError, match=f"{tmp_path / 'nope.json'}: cannot read"):
        TransferFunction.load(tmp_path / "nope.json")
