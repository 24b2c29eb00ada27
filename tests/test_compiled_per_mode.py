"""Nothing compiled or read that the scene does not need (issue 30, item 7), for ProjectedTetrahedra
and the BrickedRayCaster as docs/explanations/ray-casting.md shows it for the RayCaster: the
textures a mode's compiled program reads (its ACTIVE sampler uniforms: the GL compiler drops
every uniform the code left by the defines never uses) and the shading code only where shading is
on. The lines and texture reads per mode: ``bench/shader_cost.py`` (docs/explanations/
tetrahedra-renderer.md and bricked-ray-casting.md, "What a frame compiles and reads")."""

from __future__ import annotations

import moderngl
import pytest

from distributed_cases import bricked_network, tets_network
from vgraph.gl.shaders import programs
from vgraph.network import Network

TETRA_TEXTURES = {"transfer_function", "preintegrated", "mean_extinction", "knot_positions", "knot_values", "phi"}
READS = {"averaged": {"transfer_function"}, "preintegrated": {"preintegrated", "mean_extinction"},
         "partial": {"knot_positions", "knot_values", "phi"}}
SHADING = {"ambient", "diffuse", "specular", "shininess", "gradient_scale", "voxel_step"}


@pytest.fixture
def compiled(monkeypatch):
    """The active uniform names of every program a frame asks the cache for, by fragment shader."""
    found = {}
    original = programs.program

    def recording(ctx, vertex, fragment, *args, **kwargs):
        program = original(ctx, vertex, fragment, *args, **kwargs)
        found[fragment] = {name for name in program if isinstance(program[name], moderngl.Uniform)}
        return program

    monkeypatch.setattr(programs, "program", recording)
    return found


def cells_network(integration: str) -> Network:
    network = Network()
    network.add("FunctionSelector", id="source", function="sphere", resolution=16)
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="pt", integration=integration)
    network.connect("source.volume", "tets.volume")
    network.connect("tets.mesh", "pt.mesh")
    return network


@pytest.mark.parametrize("integration", sorted(READS))
def test_projected_tetrahedra_read_only_the_tables_of_their_integration(gl, tmp_path, compiled, integration):
    tets_network(tmp_path, integration=integration).evaluate("pt.image", size=(24, 24))
    assert compiled["tetrahedra/project.frag.glsl"] & TETRA_TEXTURES == READS[integration]
    cells_network(integration).evaluate("pt.image", size=(24, 24))
    assert compiled["tetrahedra/cells.frag.glsl"] & TETRA_TEXTURES == READS[integration]


@pytest.mark.parametrize("compositing, shading", [("dvr", "none"), ("dvr", "blinn_phong"), ("mip", "none"),
                                                  ("iso", "none"), ("iso", "blinn_phong")])
def test_brick_passes_compile_shading_and_classification_only_where_used(gl, tmp_path, compiled,
                                                                          compositing, shading):
    network = bricked_network(tmp_path, compositing=compositing, shading=shading, iso_level=0.45, method="passes")
    network.evaluate("rc.image", size=(24, 16))
    brick_pass = compiled["bricks/brick.frag.glsl"]
    assert "volume" in brick_pass and "entry_points" in brick_pass
    assert (brick_pass & SHADING == SHADING) == (shading == "blinn_phong")
    # mip classifies the maximum once, in the resolve pass: its brick passes read no TF
    assert ("transfer_function" in brick_pass) == (compositing != "mip")
    assert ("transfer_function" in compiled["bricks/resolve.frag.glsl"]) == (compositing == "mip")
