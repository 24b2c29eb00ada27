"""The .json network format: round trip, migrations, and an error naming the place for each kind
of malformed input."""

import errno
import json
import os
import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vgraph
from vgraph import NetworkFileError
from vgraph.cli import main
from vgraph.fileformat import CURRENT_VERSION, load_network, network_document

from helpers.paths import REPO
from helpers import toy_processors

for cls in toy_processors.ALL:
    vgraph.register(cls)

GOOD = {
    "format": "vgraph-network", "version": 1, "description": "two numbers summed",
    "processors": [
        {"id": "a", "type": "Number", "properties": {"value": 2.5}, "position": [10, 20]},
        {"id": "b", "type": "Number", "properties": {"value": -1}},
        {"id": "sum", "type": "Sum"},
        {"id": "out", "type": "Collect"},
    ],
    "connections": [{"from": "a.value", "to": "sum.values"}, {"from": "b.value", "to": "sum.values"},
                    {"from": "sum.value", "to": "out.value"}],
    "links": [{"from": "a.mode", "to": "b.mode", "bidirectional": True}],
}


def write(tmp_path, document, name="net.json"):
    path = tmp_path / name
    path.write_text(document if isinstance(document, str) else json.dumps(document))
    return path


def problems(tmp_path, document):
    with pytest.raises(NetworkFileError) as caught:
        load_network(write(tmp_path, document))
    assert str(tmp_path / "net.json") in str(caught.value)  # every message names the file
    return caught.value.problems


def broken(change):
    document = json.loads(json.dumps(GOOD))
    change(document)
    return document


def test_load_evaluate_save_load_is_lossless(tmp_path):
    network = load_network(write(tmp_path, GOOD))
    network.update()
    assert network.output("out") == 1.5
    assert network["a"].position == (10.0, 20.0)
    network.save(tmp_path / "again.json")
    first = json.loads((tmp_path / "again.json").read_text())
    load_network(tmp_path / "again.json").save(tmp_path / "third.json")
    assert json.loads((tmp_path / "third.json").read_text()) == first
    assert first["links"] == GOOD["links"] and first["connections"] == GOOD["connections"]


def test_every_shipped_network_round_trips(tmp_path):
    for path in sorted((REPO / "networks").glob("*.json")):
        network = vgraph.load(path)
        original = network_document(network, path.parent.resolve())
        network.save(tmp_path / path.name)  # its writers still write into networks/out: allowed
        again = network_document(vgraph.load(tmp_path / path.name, allow_write=[REPO / "networks"]),
                                 path.parent.resolve())
        assert again == original, path.name


def test_saving_elsewhere_keeps_relative_file_paths_pointing_at_the_same_file(tmp_path):
    network = vgraph.load(REPO / "networks" / "grayscale.json")
    (tmp_path / "deep").mkdir()
    network.save(tmp_path / "deep" / "moved.json")
    moved = vgraph.load(tmp_path / "deep" / "moved.json")
    assert moved["source"].resolve_path(moved.get("source.path")).resolve() == \
        (REPO / "networks" / "data" / "color_wheel.png").resolve()


def test_save_is_atomic_and_keeps_the_old_file_on_failure(tmp_path, monkeypatch):
    network = load_network(write(tmp_path, GOOD))
    target = tmp_path / "keep.json"
    target.write_text("precious")

    def fail(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(vgraph.OutputFileError, match="keep.json: No space left on device"):
        network.save(target)
    assert target.read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".keep")] == []


@pytest.mark.parametrize("document, path, reason", [
    ("{not json", "", "not valid JSON: Expecting property name .* line 1 column 2"),
    ("[1, 2]", "", "expected a JSON object, got list"),
    ('{"format": "vgraph-network", "version": NaN}', "", "NaN is not allowed"),
    (broken(lambda d: d.update(format="other")), "format", "expected \"vgraph-network\""),
    (broken(lambda d: d.update(version=99)), "version", "written by a newer vgraph"),
    (broken(lambda d: d.update(version="1")), "version", "must be an integer"),
    (broken(lambda d: d.update(extra=1)), "extra", "Extra inputs are not permitted"),
    (broken(lambda d: d["processors"][1].pop("type")), "processors[1].type", "Field required"),
    (broken(lambda d: d["processors"][0].update(position=[1])), "processors[0].position", "Field required"),
    (broken(lambda d: d["processors"][0].update(id="a.b")), "processors[0].id", "pattern"),
    (broken(lambda d: d["processors"][2].update(type="Nope")), "processors[2].type",
     "unknown processor type 'Nope'; known types: .*Canvas.*; plug-ins loaded: "),
    (broken(lambda d: d["processors"][1].update(id="a")), "processors[1].id", "duplicate processor id 'a'"),
    (broken(lambda d: d["processors"][0]["properties"].update(colour=1)), "processors[0].properties.colour",
     "Number has no property 'colour'"),
    (broken(lambda d: d["processors"][0]["properties"].update(value=1e9)), "processors[0].properties.value",
     "less than or equal to 100"),
    (broken(lambda d: d["connections"][0].update({"from": "a"})), "connections[0].from", "pattern"),
    (broken(lambda d: d["connections"].append({"from": "a.value", "to": "ghost.value"})), "connections[3]",
     "no processor with id 'ghost'"),
    (broken(lambda d: d["processors"].append({"id": "t", "type": "Text"}) or
            d["connections"].append({"from": "t.text", "to": "sum.offset"})), "connections[3]",
     "carries str but sum.offset takes float"),
    (broken(lambda d: d["processors"].append({"id": "s2", "type": "Sum"}) or d["connections"].extend(
        [{"from": "sum.value", "to": "s2.values"}, {"from": "s2.value", "to": "sum.offset"}])),
     "connections[4]", "would create a cycle"),
    (broken(lambda d: d["links"].append({"from": "a.value", "to": "b.mode"})), "links[1]",
     "cannot link a float property"),
])
def test_malformed_input_names_the_json_path_and_reason(tmp_path, document, path, reason):
    found = problems(tmp_path, document)
    assert any(p.startswith(path) and re.search(reason, r) for p, r in found), found


def test_a_version_0_label_on_a_version_1_body_is_refused_not_emptied(tmp_path):
    """It used to validate as "valid (0 processors)", and load + save wrote an empty network."""
    path = write(tmp_path, broken(lambda d: d.update(version=0)))
    before = path.read_text()
    with pytest.raises(NetworkFileError, match="version: version 0 files have no field 'connections'"):
        vgraph.load(path)
    assert main(["validate", str(path)]) == 2
    assert path.read_text() == before


def test_load_and_save_never_drop_a_processor_connection_or_link(tmp_path):
    for source in sorted((REPO / "networks").glob("*.json")):
        document = json.loads(source.read_text())
        network = vgraph.load(source)
        network.save(tmp_path / source.name)
        saved = json.loads((tmp_path / source.name).read_text())
        for part in ("processors", "connections", "links"):
            assert len(saved[part]) == len(document[part]), (source.name, part)


def nested(depth: int):
    value = 1
    for _ in range(depth):
        value = [value]
    return value


@pytest.mark.parametrize("name, make, reason", [
    ("fifo.json", lambda p: os.mkfifo(p), "not a regular file"),
    ("folder.json", lambda p: p.mkdir(), "not a regular file"),
    ("huge.json", lambda p: p.write_bytes(b" " * (64 * 2**20 + 1)), "67108865 bytes is larger than a network file can be"),
    ("deep.json", lambda p: p.write_text("[" * 100_000 + "]" * 100_000), "nested more than 64 levels"),
    ("deep_value.json", lambda p: p.write_text(json.dumps(
        broken(lambda d: d["processors"][0]["properties"].update(value=nested(70))))),
     "nested more than 64 levels"),
    ("binary.json", lambda p: p.write_bytes(b"\xff\xfe\x00garbage"), "cannot read the file"),
])
def test_files_that_are_not_networks_are_refused_before_reading_them_whole(tmp_path, name, make, reason):
    path = tmp_path / name
    make(path)
    with pytest.raises(NetworkFileError, match=rf"{name}: \(top level\): {reason}"):
        vgraph.load(path)
    assert main(["validate", str(path)]) == 2


def test_dev_zero_is_not_read_as_a_network():
    with pytest.raises(NetworkFileError, match=r"/dev/zero: \(top level\): not a regular file"):
        vgraph.load("/dev/zero")


def test_validate_checks_what_run_would_refuse(tmp_path, capsys):
    document = json.loads((REPO / "networks" / "raycast_sphere.json").read_text())
    source = next(p for p in document["processors"] if p["type"] == "FunctionSelector")
    source["properties"].update(function="sphere", parameters={"radius": -1})
    path = write(tmp_path, document)
    assert main(["validate", str(path)]) == 2
    assert re.search(r"processors\[\d\]\.properties: function 'sphere', parameter 'radius': must be in",
                     capsys.readouterr().err)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(NetworkFileError, match=r"missing\.json: \(top level\): file not found"):
        vgraph.load(tmp_path / "missing.json")


def test_all_problems_are_reported_at_once(tmp_path):
    document = broken(lambda d: (d["processors"][0]["properties"].update(value="x"),
                                 d["processors"][1].update(type="Nope")))
    paths = [p for p, _ in problems(tmp_path, document)]
    assert "processors[0].properties.value" in paths and "processors[1].type" in paths


def test_version_0_is_migrated(tmp_path):
    old = {"format": "vgraph-network", "version": 0,
           "nodes": {"a": {"type": "Number", "properties": {"value": 4}},
                     "out": {"type": "Collect", "position": [1, 2]}},
           "edges": ["a.value -> out.value"], "links": []}
    network = load_network(write(tmp_path, old))
    network.update()
    assert network.output("out") == 4.0
    network.save(tmp_path / "new.json")
    assert json.loads((tmp_path / "new.json").read_text())["version"] == CURRENT_VERSION


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=20)
documents = st.fixed_dictionaries(
    {"format": st.sampled_from(["vgraph-network", "x"]), "version": st.sampled_from([0, 1, 2, "1"])},
    optional={"processors": st.lists(st.fixed_dictionaries(
        {"id": st.sampled_from(["a", "b", "a.b", ""]), "type": st.sampled_from(["Number", "Sum", "Collect", "X"])},
        optional={"properties": st.dictionaries(st.sampled_from(["value", "mode", "q"]), json_values),
                  "position": json_values}), max_size=4),
        "connections": st.lists(st.fixed_dictionaries({"from": st.sampled_from(["a.value", "b.value", "a", 3]),
                                                      "to": st.sampled_from(["b.value", "sum.values", "x.y"])}), max_size=3),
        "links": json_values, "nodes": json_values, "edges": json_values})


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(document=st.one_of(json_values, documents))
def test_random_json_only_ever_raises_the_documented_error(tmp_path, document):
    path = write(tmp_path, json.dumps(document))
    try:
        load_network(path)
    except NetworkFileError as error:
        assert error.problems and all(isinstance(r, str) and r for _, r in error.problems)


@pytest.mark.parametrize("type_name, old, new, values", [
    ("RayCaster", "gradient", "derivatives", ("sobel", "central")),
    ("CurvatureRaycaster", "level", "iso_level", (0.25, 0.5)),
])
@pytest.mark.parametrize("command", ["validate", "run"])
def test_a_version_1_file_giving_a_value_under_its_old_and_new_name_is_refused_naming_both(
        tmp_path, capsys, type_name, old, new, values, command):
    """A migration that kept one of the two would lose the other without a word."""
    document = {"format": "vgraph-network", "version": 1, "processors": [
        {"id": "first", "type": "Number"},
        {"id": "r", "type": type_name, "properties": {old: values[0], new: values[1]}}]}
    path = write(tmp_path, document)
    assert main([command, str(path)]) == 2
    err = capsys.readouterr().err
    assert f"processors[1].properties.{old}" in err and f"processors[1].properties.{new}" in err, err
    assert json.dumps(values[0]) in err and json.dumps(values[1]) in err, err
    assert "Traceback" not in err
    with pytest.raises(NetworkFileError) as refused:
        load_network(path)
    assert [p for p, _ in refused.value.problems] == [f"processors[1].properties.{old}"]


def test_a_version_0_file_giving_a_value_under_both_names_is_refused_too(tmp_path):
    old = {"format": "vgraph-network", "version": 0,
           "nodes": {"r": {"type": "RayCaster", "properties": {"gradient": "sobel", "derivatives": "central"}}}}
    with pytest.raises(NetworkFileError, match=r"processors\[0\]\.properties\.gradient: .*"
                                               r"processors\[0\]\.properties\.derivatives"):
        load_network(write(tmp_path, old))


def test_the_old_name_alone_still_migrates(tmp_path):
    document = {"format": "vgraph-network", "version": 1, "processors": [
        {"id": "r", "type": "RayCaster", "properties": {"gradient": "sobel"}},
        {"id": "c", "type": "CurvatureRaycaster", "properties": {"level": 0.25}}]}
    network = load_network(write(tmp_path, document))
    assert network.get("r.derivatives") == "sobel" and network.get("c.iso_level") == 0.25
