"""Markups files of other tools for the tests that read them (tests/test_markups.py,
test_gui_markups.py): a 3D Slicer markups file (.mrk.json) holding a line in LPS and an angle in RAS."""

SLICER_LINE = """{
  "@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#",
  "markups": [{
    "type": "Line", "coordinateSystem": "LPS", "coordinateUnits": "mm", "locked": false,
    "controlPoints": [
      {"id": "1", "label": "L-1", "position": [10.5, -20.0, 30.0], "orientation": [-1.0, -0.0, -0.0, -0.0, -1.0, -0.0, 0.0, 0.0, 1.0], "selected": true, "locked": false, "visibility": true, "positionStatus": "defined"},
      {"id": "2", "label": "L-2", "position": [13.5, -16.0, 30.0], "selected": true, "locked": false, "visibility": true, "positionStatus": "defined"}],
    "measurements": [{"name": "length", "enabled": true, "value": 5.0, "units": "mm", "printFormat": "%-#4.4gmm"}],
    "display": {"visibility": true, "opacity": 1.0}
  }, {
    "type": "Angle", "coordinateSystem": "RAS",
    "controlPoints": [{"label": "A-1", "position": [1.0, 0.0, 0.0]}, {"label": "A-2", "position": [0.0, 0.0, 0.0]},
                      {"label": "A-3", "position": [0.0, 2.0, 0.0]}]
  }]
}"""
