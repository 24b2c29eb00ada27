"""What each mode compiles and reads (issue 30, item 7: nothing compiled or read that the scene does
not need), for the RayCaster, the BrickedRayCaster and ProjectedTetrahedra.

    nice -n 10 .venv/bin/python bench/shader_cost.py

Per mode, one small frame is drawn with an empty program cache, and every shader the frame
compiles is recorded as it is composed (``vgraph.gl.shaders.compose``). Each composed source is
run through the C preprocessor (``cpp -P``, the system's: the GLSL #if/#ifdef branches the
defines leave out are dropped, as the GL compiler drops them) and counted:

- lines: the non-blank lines the compiler gets, over every program of the frame (vertex,
  geometry and fragment stages; the fragment stage of the renderer's own program apart);
- fetches: the texture reads written in the renderer's fragment stage (``texture``,
  ``textureLod``, ``texelFetch`` call sites; a loop's body, or a function called for each of a
  gradient's six samples, counts once), i.e. which reads the code holds, not how often they run;
- textures: the samplers of that fragment stage the compiled program keeps active (the GL compiler
  drops those the code never reads).

And for the BrickedRayCaster under a spike transfer function one data unit wide: the bricks of
the volume, those planned (non-empty under the TF) and those read from the volume.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from pathlib import Path

import moderngl

import vgraph.gl.shaders as shaders
from distributed_cases import bricked_network, spike_tf, tets_network
from vgraph.gl.shaders import programs

SAMPLER = re.compile(r"uniform\s+[iu]?sampler\w+\s+(\w+)")
FETCH = re.compile(r"\b(texture|textureLod|texelFetch|textureGrad|textureOffset)\s*\(")


def preprocessed(text: str) -> str:
    """The source as the GL compiler sees it once the preprocessor has run (#version and
    #extension lines dropped first: cpp does not know them)."""
    kept = "\n".join(line for line in text.splitlines() if not line.lstrip().startswith(("#version", "#extension")))
    return subprocess.run(["cpp", "-P", "-undef", "-nostdinc"], input=kept, capture_output=True, text=True,
                          check=True).stdout


def count(text: str) -> tuple[int, int]:
    code = preprocessed(text)
    lines = [line for line in code.splitlines() if line.strip()]
    return len(lines), len(FETCH.findall(code))


def recorded_frame(draw) -> tuple[list, dict]:
    """(every ComposedSource that ``draw()`` compiles, an empty cache first; the active uniform
    names of each program it asks for, by fragment shader)."""
    composed, active, original, original_program = [], {}, shaders.compose, programs.program

    def recording(*args, **kwargs):
        source = original(*args, **kwargs)
        composed.append(source)
        return source

    def program(ctx, vertex, fragment, *args, **kwargs):
        made = original_program(ctx, vertex, fragment, *args, **kwargs)
        active[fragment] = {name for name in made if isinstance(made[name], moderngl.Uniform)}
        return made

    programs.clear()
    shaders.compose, programs.program = recording, program
    try:
        draw()
    finally:
        shaders.compose = original
        del programs.program  # the class's method again
    return composed, active


def row(label: str, draw, own_fragment: str) -> str:
    sources, active = recorded_frame(draw)
    total = sum(count(source.text)[0] for source in sources)
    own = [source for source in sources if source.name == own_fragment]
    lines, fetches = count(own[0].text) if own else (0, 0)
    read = sorted(set(SAMPLER.findall(preprocessed(own[0].text))) & active.get(own_fragment, set())) if own else []
    return f"| {label} | {len(sources)} | {total} | {lines} | {fetches} | {', '.join(read)} |"


def ray_caster_rows(folder: Path, kind: str):
    fragment = {"RayCaster": "raycasting/raycaster.frag.glsl",
                "BrickedRayCaster": "bricks/brick.frag.glsl"}[kind]
    for compositing in ("dvr", "mip", "iso"):
        for shading in ("none", "blinn_phong"):
            if compositing == "mip" and shading != "none":
                continue
            network = bricked_network(folder, compositing=compositing, shading=shading, iso_level=45.0 / 100.0)
            if kind == "RayCaster":
                network.remove("rc")
                network.add("RayCaster", id="rc", compositing=compositing, shading=shading, iso_level=0.45)
                network.link("eep.camera", "rc.camera")
                for source, target in (("source.volume", "rc.volume"), ("eep.entry", "rc.entry"),
                                       ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
                    network.connect(source, target)
            yield row(f"{kind} {compositing}, shading {shading}",
                      lambda n=network: n.evaluate("rc.image", size=(32, 24)), fragment)


def tetrahedra_rows(folder: Path):
    for integration in ("averaged", "preintegrated", "partial"):
        network = tets_network(folder, integration=integration)
        yield row(f"ProjectedTetrahedra {integration}, tetrahedra",
                  lambda n=network: n.evaluate("pt.image", size=(32, 32)), "tetrahedra/project.frag.glsl")
    for integration in ("averaged", "preintegrated", "partial"):
        from vgraph.network import Network
        network = Network()
        network.add("FunctionSelector", id="source", function="sphere", resolution=16)
        network.add("VolumeToTetMesh", id="tets")
        network.add("ProjectedTetrahedra", id="pt", integration=integration)
        network.connect("source.volume", "tets.volume")
        network.connect("tets.mesh", "pt.mesh")
        yield row(f"ProjectedTetrahedra {integration}, grid cells",
                  lambda n=network: n.evaluate("pt.image", size=(32, 32)), "tetrahedra/cells.frag.glsl")


def bricks_under_a_spike(folder: Path) -> str:
    """Bricks of a 96^3 ball, planned and read under a spike one data unit wide at 90 (only the
    bricks around the centre hold that value)."""
    network = bricked_network(folder, shape=(96, 96, 96), transfer_function=spike_tf(90.0))
    network.evaluate("rc.image", size=(64, 48))
    frame = network["rc"].last_frame
    return (f"BrickedRayCaster, 96^3 ball in 16^3 bricks ({6 ** 3}), spike TF at 90: {frame['bricks']} "
            f"bricks planned, {frame['bricks_read']} read")


def main() -> int:
    print("| mode | shaders composed | lines compiled (all stages) | lines of the renderer's fragment stage | "
          "texture reads written there | textures it reads |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as temporary:
        folder = Path(temporary)
        for rows in (ray_caster_rows(folder, "RayCaster"), ray_caster_rows(folder, "BrickedRayCaster"),
                     tetrahedra_rows(folder)):
            for line in rows:
                print(line, flush=True)
        print()
        print(bricks_under_a_spike(folder))
    return 0


if __name__ == "__main__":
    sys.exit(main())
