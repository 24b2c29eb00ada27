"""Helpers shared by the tests: plain functions, classes and constants, imported as
``from helpers.paths import REPO`` or ``from helpers.gui import drag``.

Fixtures (``window``, ``renderer``, ``gl``, ``data_dir``, ``test_shader_dir``) live in
``tests/conftest.py``, which pytest gives every test without an import. No test module imports
another test module: what two test files share belongs here.
A fixture that only some test modules share is defined in its helper and named in each of them
(``bonsai = helpers.bricked.bonsai``), as pytest finds fixtures only in test modules and conftest.

- ``paths``: REPO (the repository), BENCH (the tools the bench shares with the tests: fuzz cases,
  the scripted user; conftest puts it on sys.path) and DATA (the shared data sets beside it)
- ``toy_processors``: small CPU processors (no GL); conftest registers them for every test
- ``gui``: mouse helpers for the GUI tests
- ``canvas``: a canvas view alone, shown at SIZE, and a mouse drag in it
- ``dicom``: DICOM files written by pydicom (a one-slice axial CT)
- ``foreign_stores``: OME-Zarr images written by ome-zarr-py, opened with every level (skips without it)
- ``markups_files``: markups files of other tools (a 3D Slicer .mrk.json)
- ``meshes``: the tetrahedral meshes' blob volume and its network (written, cut, projected)
- ``networks``: networks the rendering tests build
- ``raycaster``: the RayCaster's tolerance against the CPU reference, its transfer functions, SIZE and
  oblique camera
- ``curvature``: the curvature ray casters' networks and CPU references
- ``bricked``: the bricked ray caster's test volumes, cameras, transfer function and render()
- ``sweep``: the SweepPlaneRenderer's volumes, cameras, transfer function and exact reference
- ``refining``: the single pass's refining frames drawn walked and marched (mip and iso tests)
- ``skipping``: empty-space skipping's pictures compared bit for bit, their cameras, a noise volume,
  a brick's blocks' ranges
"""
