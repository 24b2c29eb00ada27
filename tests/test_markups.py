"""Markups (issue 36, item 2): the model's measurements, the property in a network file and its
named errors, CSV / JSON / Slicer markups files, the overlay's pixels against the camera's
projection and the renderer's depth, the measurement table (and its CSV from the CLI), undo."""

import csv
import json
import math

import numpy as np
import pytest

from vgraph import Network
from vgraph.cli import main
from vgraph.edits import SetProperty
from vgraph.errors import NetworkFileError, PropertyError
from vgraph.fileformat import load_network, save_network
from vgraph.markups import Markup, Markups
from vgraph.markups_files import MarkupsFileError, read_markups, write_markups

from picking_sphere import CENTRE, RADIUS, sphere_network

from helpers.markups_files import SLICER_LINE

SIZE = 201  # the overlay tests' image (odd: the view's centre is pixel 100); the view is 2 x 1.3 R high
PER_UNIT = SIZE / (2 * 1.3 * RADIUS)

RULER = {"name": "r1", "kind": "ruler", "points": [[1.0, 2.0, 3.0], [4.0, 6.0, 3.0]]}
ANGLE = {"name": "a1", "kind": "angle", "points": [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]}
SQUARE = {"name": "c1", "kind": "closed_curve",
          "points": [[0.0, 0.0, 5.0], [2.0, 0.0, 5.0], [2.0, 3.0, 5.0], [0.0, 3.0, 5.0]]}
POINTS = {"name": "p1", "kind": "points", "points": [[-1.5, 2.25, 7.0], [0.125, 1e-3, -2.0]]}
ALL = [RULER, ANGLE, SQUARE, POINTS]


# --- the model ----------------------------------------------------------------------------------
def test_lengths_angles_and_areas():
    markups = Markups.model_validate({"markups": ALL})
    assert markups["r1"].length == 5.0 and markups["r1"].angle is None
    assert markups["a1"].angle == pytest.approx(45.0, abs=1e-12) and markups["a1"].length is None
    assert markups["c1"].length == pytest.approx(10.0) and markups["c1"].area == pytest.approx(6.0)
    assert markups["p1"].length is None and markups["p1"].area is None
    right = Markup(name="right", kind="angle", points=((0, 5, 1), (0, 0, 1), (0, 0, 7)))
    assert right.angle == pytest.approx(90.0, abs=1e-12)
    # near 180 degrees atan2 keeps the digits acos of the cosine loses
    tiny = 1e-7
    straight = Markup(name="s", kind="angle", points=((-1, 0, 0), (0, 0, 0), (1, tiny, 0)))
    assert straight.angle == pytest.approx(180.0 - math.degrees(tiny), abs=1e-12)
    # a tilted plane: a regular hexagon of side 2 in the plane x + y + z = 1
    u, v = np.array([1, -1, 0]) / np.sqrt(2), np.array([1, 1, -2]) / np.sqrt(6)
    hexagon = [tuple(np.array([1, 0, 0]) + 2 * (np.cos(a) * u + np.sin(a) * v))
               for a in np.arange(6) * np.pi / 3]
    curve = Markup(name="hex", kind="closed_curve", points=hexagon)
    assert curve.length == pytest.approx(12.0) and curve.area == pytest.approx(3 * np.sqrt(3) / 2 * 4)


def test_edits_make_new_values_and_names_are_unique():
    markups = Markups.model_validate({"markups": [RULER]})
    moved = markups.with_markup(Markup.model_validate({**RULER, "points": [[0, 0, 0], [0, 0, 2]]}))
    assert markups["r1"].length == 5.0 and moved["r1"].length == 2.0 and moved.names == ["r1"]
    assert moved.with_markup(Markup.model_validate(ANGLE)).names == ["r1", "a1"]
    assert moved.without("r1").names == []
    with pytest.raises(KeyError, match="no markup named 'x'"):
        moved.without("x")
    with pytest.raises(ValueError, match="two markups are named 'r1'"):
        Markups.model_validate({"markups": [RULER, RULER]})


@pytest.mark.parametrize("markup, reason", [
    ({**RULER, "points": [[0, 0, 0]]}, "a ruler has exactly 2 points, got 1"),
    ({**ANGLE, "points": [[0, 0, 0], [1, 1, 1]]}, "an angle has exactly 3 points, got 2"),
    ({**ANGLE, "points": [[0, 0, 0], [0, 0, 0], [1, 1, 1]]}, "an angle's arm has zero length"),
    ({**SQUARE, "points": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 1]]}, "a closed curve lies in one plane"),
    ({**SQUARE, "points": [[0, 0, 0], [1, 1, 1], [2, 2, 2]]}, "all lie on one line"),
    ({**RULER, "points": [[0, float("nan"), 0], [1, 1, 1]]}, "finite number"),
    ({**RULER, "points": [[0, 1e16, 0], [1, 1, 1]]}, "less than or equal to 1000000000000000"),
    ({**RULER, "points": [[0, True, 0], [1, 1, 1]]}, "not a boolean"),
    ({**RULER, "name": "a\nb"}, "printable characters only"),
    ({**RULER, "name": "x" * 201}, "at most 200 characters"),
    ({**RULER, "kind": "circle"}, "'points', 'ruler', 'angle' or 'closed_curve'"),
])
def test_bad_markups_are_refused_by_name(markup, reason):
    network = Network()
    network.add("Markups", id="mk")
    with pytest.raises(PropertyError) as error:
        network.set("mk.markups", [markup])
    assert "mk.markups" in str(error.value) and reason in str(error.value)


# --- the network file ---------------------------------------------------------------------------
def test_markups_round_trip_through_a_saved_network(tmp_path):
    network = Network()
    network.add("Markups", id="mk", markups=ALL)
    save_network(network, tmp_path / "net.json")
    stored = json.loads((tmp_path / "net.json").read_text())["processors"][0]["properties"]["markups"]
    assert stored["markups"][0] == {**RULER, "visible": True}
    loaded = load_network(tmp_path / "net.json")
    assert loaded["mk"].markups == network["mk"].markups
    assert loaded["mk"].markups["c1"].area == pytest.approx(6.0)


def test_a_bad_markup_in_a_network_file_names_file_processor_and_field(tmp_path):
    document = {"format": "vgraph-network", "version": 3, "connections": [], "links": [], "processors": [
        {"id": "mk", "type": "Markups", "properties": {"markups": [{**ANGLE, "points": [[0, 0, 0]]}]}}]}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document))
    with pytest.raises(NetworkFileError) as error:
        load_network(path)
    message = str(error.value)
    assert str(path) in message and "processors[0].properties.markups" in message
    assert "an angle has exactly 3 points, got 1" in message


def test_markup_edits_are_undone_through_the_edits_api():
    network = Network()
    network.add("Markups", id="mk", markups=[RULER])
    edit = SetProperty.of(network, "mk.markups", [RULER, ANGLE])
    edit.apply(network)
    assert network["mk"].markups.names == ["r1", "a1"]
    edit.inverse().apply(network)
    assert network["mk"].markups == Markups.model_validate({"markups": [RULER]})
    edit.apply(network)  # redo
    assert network["mk"].markups["a1"].angle == pytest.approx(45.0)


# --- files --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["m.csv", "m.json", "m.mrk.json"])
def test_markups_round_trip_through_csv_json_and_slicer_files(tmp_path, name):
    markups = Markups.model_validate({"markups": ALL})
    write_markups(markups, tmp_path / name)
    assert read_markups(tmp_path / name) == markups
    assert [p.name for p in tmp_path.iterdir()] == [name]  # atomic: no temporary left


def test_csv_has_one_row_per_point_with_every_digit(tmp_path):
    write_markups(Markups.model_validate({"markups": [POINTS]}), tmp_path / "p.csv")
    rows = list(csv.reader((tmp_path / "p.csv").open()))
    assert rows == [["name", "kind", "point", "x", "y", "z"],
                    ["p1", "points", "0", "-1.5", "2.25", "7.0"], ["p1", "points", "1", "0.125", "0.001", "-2.0"]]


def test_a_slicer_file_in_lps_is_read_into_ras(tmp_path):
    path = tmp_path / "Measure.mrk.json"
    path.write_text(SLICER_LINE)
    markups = read_markups(path)
    assert markups.names == ["Measure-1", "Measure-2"]
    line, angle = markups.markups
    assert line.kind == "ruler" and line.points == ((-10.5, 20.0, 30.0), (-13.5, 16.0, 30.0))  # LPS -> RAS
    assert line.length == pytest.approx(5.0)  # as Slicer measured it
    assert angle.kind == "angle" and angle.points[2] == (0.0, 2.0, 0.0) and angle.angle == pytest.approx(90.0)
    write_markups(markups, tmp_path / "again.mrk.json")
    written = json.loads((tmp_path / "again.mrk.json").read_text())["markups"][0]
    assert written["type"] == "Line" and written["coordinateSystem"] == "LPS"
    assert written["controlPoints"][0]["position"] == [10.5, -20.0, 30.0]


@pytest.mark.parametrize("change, where, reason", [
    (lambda d: d["markups"][0].update(type="ROI"), "markups[0].type", "'ROI' is not a markup vgraph holds"),
    (lambda d: d["markups"][0].update(coordinateSystem="IJK"), "markups[0].coordinateSystem", "must be LPS or RAS"),
    (lambda d: d["markups"][0]["controlPoints"][1].update(position=[1, 2]), "markups[0].controlPoints[1].position",
     "three finite numbers"),
    (lambda d: d["markups"][0]["controlPoints"].pop(), "markups[0]", "a ruler has exactly 2 points, got 1"),
])
def test_bad_slicer_files_are_refused_naming_file_and_place(tmp_path, change, where, reason):
    document = json.loads(SLICER_LINE)
    change(document)
    path = tmp_path / "bad.mrk.json"
    path.write_text(json.dumps(document))
    with pytest.raises(MarkupsFileError) as error:
        read_markups(path)
    assert str(error.value).startswith(f"{path}: {where}") and reason in str(error.value)


def test_bad_csv_and_json_files_are_refused_by_name(tmp_path):
    (tmp_path / "nan.csv").write_text("name,kind,point,x,y,z\nr,ruler,0,1,2,nan\nr,ruler,1,1,2,3\n")
    with pytest.raises(MarkupsFileError, match=r"nan.csv: line 2: z must be a finite number"):
        read_markups(tmp_path / "nan.csv")
    (tmp_path / "nan.json").write_text('{"markups": [{"name": "r", "kind": "ruler", '
                                       '"points": [[0, 0, NaN], [1, 1, 1]]}]}')
    with pytest.raises(MarkupsFileError, match=r"nan.json: NaN is not a number a markups file may hold"):
        read_markups(tmp_path / "nan.json")
    with pytest.raises(MarkupsFileError, match=r"must end in .csv, .json or .mrk.json"):
        write_markups(Markups(), tmp_path / "m.txt")


# --- the overlay --------------------------------------------------------------------------------
def overlay_network(markups, with_depth=True, hidden_opacity=0.0):
    """The analytic sphere (radius 10, seen along -z, orthographic) with the Markups over it in red."""
    network = sphere_network(1.0)
    network.add("Markups", id="mk", color=(1.0, 0.0, 0.0, 1.0), labels=False, line_width=1, point_size=0.0,
                markups=markups, hidden_opacity=hidden_opacity)
    network.link("eep.camera", "mk.camera")
    for source, target in (("rc.image", "mk.image"), ("src.volume", "mk.volume")) + \
            ((("rc.depth", "mk.depth"),) if with_depth else ()):
        network.connect(source, target)
    return network


def red_pixels(network):
    pixels = network.evaluate("mk.image", size=(SIZE, SIZE))
    return (pixels[..., 0] > 0.9) & (pixels[..., 1] < 0.1) & (pixels[..., 2] < 0.1)


def column_of(x):
    return (x - CENTRE[0]) * PER_UNIT + (SIZE - 1) / 2


def row_of(y):
    return (SIZE - 1) / 2 - (y - CENTRE[1]) * PER_UNIT


def test_a_ruler_in_front_of_the_sphere_is_drawn_where_the_camera_projects_it():
    cx, cy, cz = CENTRE
    ruler = {"name": "front", "kind": "ruler", "points": [[cx - 12, cy + 5, cz + 12], [cx + 12, cy + 5, cz + 12]]}
    red = red_pixels(overlay_network([ruler]))
    rows, columns = np.nonzero(red)
    assert abs(np.median(rows) - row_of(cy + 5)) <= 0.5
    # Pillow rounds a line's ends: a pixel and a half at most beyond the projected points
    assert abs(columns.min() - column_of(cx - 12)) <= 1.5 and abs(columns.max() - column_of(cx + 12)) <= 1.5
    line = red[round(row_of(cy + 5))]
    assert line[round(column_of(cx - 11)):round(column_of(cx + 11))].all()  # unbroken over the sphere


def test_a_ruler_through_the_sphere_is_hidden_behind_it_and_drawn_without_depth():
    cx, cy, cz = CENTRE
    ruler = {"name": "middle", "kind": "ruler", "points": [[cx - 14, cy, cz], [cx + 14, cy, cz]]}
    row = round(row_of(cy))
    hidden = red_pixels(overlay_network([ruler]))[row]
    inside = slice(round(column_of(cx - RADIUS)) + 2, round(column_of(cx + RADIUS)) - 1)
    assert not hidden[inside].any()                       # behind the sphere's front
    assert hidden[round(column_of(cx - 13)):round(column_of(cx - RADIUS)) - 1].all()  # beside it, drawn
    assert hidden[round(column_of(cx + RADIUS)) + 2:round(column_of(cx + 13))].all()
    shown = red_pixels(overlay_network([ruler], with_depth=False))[row]
    assert shown[inside].all()
    # hidden parts drawn faintly: red at 0.4 over the sphere's pixels, which stay theirs elsewhere
    faint = overlay_network([ruler], hidden_opacity=0.4)
    pixels = faint.evaluate("mk.image", size=(SIZE, SIZE))
    sphere = faint.evaluate("rc.image", size=(SIZE, SIZE))
    expected = 0.6 * sphere[row, inside, :3] + 0.4 * np.array([1.0, 0.0, 0.0])
    np.testing.assert_allclose(pixels[row, inside, :3], expected, atol=2 / 255)
    np.testing.assert_array_equal(pixels[row - 3], sphere[row - 3])


def test_angles_points_curves_and_labels_draw_and_invisible_markups_do_not():
    cx, cy, cz = CENTRE
    front = cz + 12
    markups = [{"name": "a", "kind": "angle", "points": [[cx + 5, cy, front], [cx, cy, front], [cx, cy + 5, front]]},
               {"name": "hidden", "kind": "ruler", "points": [[cx - 12, cy - 8, front], [cx + 12, cy - 8, front]],
                "visible": False}]
    network = overlay_network(markups)
    red = red_pixels(network)
    assert red[round(row_of(cy)), round(column_of(cx + 2))]          # the first arm
    assert red[round(row_of(cy + 2)), round(column_of(cx))]          # the second arm
    arc = 0.25 * 5 * np.array([np.cos(np.pi / 4), np.sin(np.pi / 4)])  # the arc's middle
    assert red[round(row_of(cy + arc[1])), round(column_of(cx + arc[0]))]
    assert not red[round(row_of(cy - 8))].any()                       # not visible: not drawn
    network.set("mk.labels", True)
    labelled = red_pixels(network)
    label_box = labelled[:round(row_of(cy)), round(column_of(cx)) + 1:]
    assert label_box.sum() > red[:round(row_of(cy)), round(column_of(cx)) + 1:].sum() + 20  # the text


def test_the_table_lists_measurements_and_the_cli_writes_it(tmp_path, capsys):
    network = Network()
    network.add("Markups", id="mk", markups=ALL)
    table = network.evaluate("mk.table")
    assert list(table["name"]) == ["r1", "a1", "c1", "p1"]
    np.testing.assert_allclose(table["length"], [5.0, np.nan, 10.0, np.nan])
    np.testing.assert_allclose(table["angle"], [np.nan, 45.0, np.nan, np.nan])
    np.testing.assert_allclose(table["area"], [np.nan, np.nan, 6.0, np.nan])
    save_network(network, tmp_path / "net.json")
    out = tmp_path / "m.csv"
    assert main(["run", str(tmp_path / "net.json"), "--port", "mk.table", "--data", str(out)]) == 0
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["name", "kind", "points", "length [world]", "angle [degrees]", "area [world^2]"]
    assert rows[1] == ["r1", "ruler", "2", "5.0", "nan", "nan"]


def test_the_image_output_needs_an_image_and_a_camera_it_can_resolve():
    network = Network()
    network.add("Markups", id="mk", markups=[RULER])
    with pytest.raises(Exception, match="connect the renderer's image"):
        network.evaluate("mk.image", size=(32, 32))


def test_under_perspective_a_point_placed_at_a_pick_is_drawn_on_the_picked_pixel():
    """Picking and drawing agree: the world point picked under a pixel (perspective, the camera
    resolved on the volume) is drawn as a disc centred on that pixel, in front of the depth."""
    network = overlay_network([])
    camera = network.get("eep.camera")
    network.set("eep.camera", camera.model_copy(update={"projection": "perspective", "fov": 40.0}))
    network.set("mk.point_size", 5 / SIZE)  # a disc 5 pixels across
    network.set("canvas.size", (SIZE, SIZE))
    network.update("mk.image", size=(SIZE, SIZE))
    pixel = (120, 83)
    result = network.pick("canvas", *pixel)
    assert result.hit
    network.set("mk.markups", [{"name": "p", "kind": "points", "points": [list(result.point)]}])
    rows, columns = np.nonzero(red_pixels(network))
    assert len(rows) >= 9
    assert abs(columns.mean() - pixel[0]) <= 0.5 and abs(rows.mean() - pixel[1]) <= 0.5
