"""SweepPlaneRenderer against ProjectedTetrahedra's averaged mode on the same volumes, camera and
TF, both against the exact reference (issue 34: "within the averaged model's own error"). Their
cell models differ: the sweep reads the trilinear field exactly on a hexahedral cell's faces and
averages colour and extinction over one segment per cell; the tetrahedra (five per cell) hold a
field linear in each tetrahedron (not the trilinear one, even on the cell's faces) and take the TF
at the mean scalar of up to five shorter segments per cell. So their errors differ in size and
place (docs/explanations/sweep-plane.md, "Error against the exact reference")."""

from __future__ import annotations

import pytest

from vgraph.network import Network
from vgraph.sweep.render import render
from vgraph.testing import GivenVolume

from helpers.sweep import PROJECTIONS, SIZE, TF, camera, exact, psnr, smooth_volume, step_volume

# Measured (64 x 64, 24^3): sweep - tetrahedra = +6.1 / +6.5 dB smooth, -2.0 / -1.0 dB step
# (perspective / orthographic); the band allows the sweep 3 dB below the tetrahedra.
BAND_DB = 3.0


def tetrahedra_image(volume, projection):
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="pt", transfer_function=TF, integration="averaged",
                camera=camera(projection), background=(0.0, 0.0, 0.0, 1.0))
    network.connect("src.volume", "tets.volume")
    network.connect("tets.mesh", "pt.mesh")
    return network.evaluate("pt.image", size=SIZE)


@pytest.mark.parametrize("projection", PROJECTIONS)
@pytest.mark.parametrize("make_volume", [smooth_volume, step_volume], ids=["smooth", "step"])
def test_sweep_is_within_the_band_of_projected_tetrahedra_averaged(gl, make_volume, projection):
    volume = make_volume()
    reference = exact(volume, projection)
    swept = psnr(render(volume, camera(projection), TF, SIZE).image, reference)
    tetrahedra = psnr(tetrahedra_image(volume, projection), reference)
    assert tetrahedra > 45.0  # the comparison is with a working averaged renderer (measured 48-61 dB)
    assert swept > tetrahedra - BAND_DB


def test_on_the_smooth_volume_the_sweep_is_more_accurate_than_the_tetrahedra(gl):
    # measured 66.9 against 60.8 dB: where the field is smooth, the tetrahedra's piecewise-linear
    # field is further from the trilinear one than the sweep's average over a cell is
    volume = smooth_volume()
    reference = exact(volume, "perspective")
    swept = psnr(render(volume, camera("perspective"), TF, SIZE).image, reference)
    assert swept > psnr(tetrahedra_image(volume, "perspective"), reference) + 3.0
