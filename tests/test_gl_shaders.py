"""Shader composition (#include, #define, line map), compiler errors mapped to file and line, the
program cache, and fullscreen passes on the shared context (Mesa llvmpipe here)."""

from pathlib import Path

import numpy as np
import pytest

from vgraph.errors import ShaderError, VGraphError
from vgraph import gl_context
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import (ProgramCache, add_shader_dir, builtin_shader_dir, compose,
                               define_lines, format_define_value, parse_compiler_log,
                               shader_dirs, shader_error_from_log)
from vgraph.image import Image

TEST_SHADERS = Path(__file__).parent / "shaders"
pytestmark = pytest.mark.usefixtures("test_shader_dir")   # on the search path during each test only


@pytest.fixture(scope="module")
def ctx():
    return gl_context.get_context()


def fixture(name):
    return str((TEST_SHADERS / name).resolve())


# ---------------------------------------------------------------------------- search path

def test_search_path_starts_with_the_installed_shader_package():
    assert builtin_shader_dir().resolve() == (Path(__file__).parents[1] / "shaders").resolve()  # src/vgraph/shaders links there
    assert shader_dirs()[0] == builtin_shader_dir()
    assert TEST_SHADERS.resolve() in shader_dirs()
    add_shader_dir(TEST_SHADERS)  # adding twice does not duplicate
    assert shader_dirs().count(TEST_SHADERS.resolve()) == 1


def test_adding_a_missing_directory_is_an_error(tmp_path):
    with pytest.raises(ShaderError, match="does not exist"):
        add_shader_dir(tmp_path / "nope")


# ---------------------------------------------------------------------------- composition

def test_compose_expands_includes_once_and_places_version_then_defines():
    src = compose("composed.frag.glsl", {"SCALE": 0.5, "USE_B": True, "OFF": False, "NONE": None})
    lines = src.text.splitlines()
    assert lines[:3] == ["#version 330", "#define SCALE 0.5", "#define USE_B"]
    assert "OFF" not in src.text and "NONE" not in src.text
    # lib_a and lib_b include each other and composed.frag.glsl includes both: each appears once.
    assert src.text.count("float lib_a()") == 1 and src.text.count("float lib_b()") == 1
    assert "#include" not in src.text
    assert lines.index("float lib_b() { return 2.0; }") < lines.index("float lib_a() { return 1.0; }")
    assert src.files == (fixture("composed.frag.glsl"), fixture("lib_a.glsl"), fixture("lib_b.glsl"))


def test_line_map_points_every_composed_line_at_its_source():
    src = compose("composed.frag.glsl", {"SCALE": 1.0, "USE_B": True})
    top, lib_a, lib_b = fixture("composed.frag.glsl"), fixture("lib_a.glsl"), fixture("lib_b.glsl")
    assert src.line_map[:7] == ((top, 2), ("<defines>", 1), ("<defines>", 2), (top, 1),
                                (lib_a, 1), (lib_b, 2), (lib_a, 3))
    assert src.line_map[7] == (top, 5)
    assert len(src.line_map) == len(src.text.splitlines())
    # every mapped line has the text of the original line
    for composed_line, (file, line) in zip(src.text.splitlines(), src.line_map):
        if file != "<defines>":
            assert Path(file).read_text().splitlines()[line - 1] == composed_line
    assert src.origin(8) == (top, 5)
    assert src.origin(10_000) == (top, None)


def test_shader_without_version_gets_version_330(ctx):
    src = compose("lib_a.glsl")
    assert src.text.splitlines()[0] == "#version 330"
    assert src.line_map[0] == (fixture("lib_a.glsl"), 0)


@pytest.mark.parametrize("value, text", [
    (True, ""), (1, "1"), (np.int64(7), "7"), (1.0, "1.0"), (0.25, "0.25"), (np.float32(2.0), "2.0"),
    (1e-5, "1e-05"), (-3.5, "-3.5"), ("vec3(1.0)", "vec3(1.0)"), (False, None), (None, None)])
def test_define_values_are_formatted_for_glsl(value, text):
    assert format_define_value("KEY", value) == text


def test_define_lines_are_sorted_and_canonical():
    assert define_lines({"B": 2.0, "A": True, "C": False}) == ("#define A", "#define B 2.0")
    assert define_lines({"C": False}) == define_lines(None) == ()


@pytest.mark.parametrize("key, value, message", [
    ("1BAD", 1, "not a GLSL identifier"), ("X", float("nan"), "not a finite number"),
    ("X", "a\nb", "single line"), ("X", [1, 2], "use bool, int, float or str")])
def test_bad_defines_are_rejected(key, value, message):
    with pytest.raises(ShaderError, match=message):
        define_lines({key: value})


def test_missing_include_names_the_including_file_and_line():
    with pytest.raises(ShaderError) as info:
        compose("missing_include.frag.glsl", processor="Blur1")
    err = info.value
    assert err.file == fixture("missing_include.frag.glsl") and err.line == 3
    assert err.processor == "Blur1"
    assert "does_not_exist.glsl" in str(err) and f"{err.file}:3" in str(err)


def test_unknown_shader_name_is_an_error():
    with pytest.raises(ShaderError, match="'nowhere.frag.glsl' not found"):
        compose("nowhere.frag.glsl")


# ---------------------------------------------------------------------------- compiler errors

def test_compile_error_names_file_line_and_processor(ctx):
    cache = ProgramCache()
    with pytest.raises(ShaderError) as info:
        cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "broken.frag.glsl", {"X": 1.0}, processor="Probe")
    err = info.value
    # line 9 of broken.frag.glsl, although the composed source has a define and lib_a/lib_b above it
    assert (err.file, err.line, err.processor) == (fixture("broken.frag.glsl"), 9, "Probe")
    assert "undeclared_on_purpose" in str(err)
    assert str(err).startswith(f"processor Probe: {fixture('broken.frag.glsl')}:9: fragment shader:")


def test_compile_error_inside_an_include_names_the_included_file(ctx):
    with pytest.raises(ShaderError) as info:
        ProgramCache().program(ctx, FULLSCREEN_VERTEX_SHADER, "uses_broken_lib.frag.glsl")
    assert (info.value.file, info.value.line) == (fixture("broken_lib.glsl"), 3)


def test_link_error_names_both_shaders(ctx):
    with pytest.raises(ShaderError) as info:
        ProgramCache().program(ctx, "wrong_uv.vert.glsl", "uv.frag.glsl", processor="Probe")
    text = str(info.value)
    assert text.startswith("processor Probe: link error in wrong_uv.vert.glsl + uv.frag.glsl:")
    assert "`uv'" in text and "vec3" in text  # Mesa's reason: the types of uv differ


def test_nvidia_and_mesa_logs_are_parsed():
    mesa = "GLSL Compiler failed\n\nfragment_shader\n===\n0:4(11): error: `x' undeclared\n"
    nvidia = ("GLSL Compiler failed\n\nvertex_shader\n===\n0(12) : warning C7050: unused\n"
              '0(7) : error C1008: undefined variable "x"\n')
    assert parse_compiler_log(mesa) == [("fragment", 4, "`x' undeclared")]
    assert parse_compiler_log(nvidia) == [("vertex", 7, 'undefined variable "x"')]
    src = compose("composed.frag.glsl", {"SCALE": 1.0, "USE_B": True})  # line 7 = lib_a.glsl:3
    err = shader_error_from_log(nvidia.replace("vertex", "fragment"), {"fragment": src}, "P")
    assert (err.file, err.line, err.processor) == (fixture("lib_a.glsl"), 3, "P")


# ---------------------------------------------------------------------------- the cache

def test_cache_compiles_once_per_define_set(ctx):
    cache = ProgramCache()
    first = cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl", {"RED": 0.5})
    again = cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl", {"RED": 0.5})
    assert again is first and cache.compile_count == 1
    # False/None defines produce the same source, so they are the same define set
    same = cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl",
                         {"RED": 0.5, "GREEN_ON": False})
    assert same is first and cache.compile_count == 1
    green = cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl",
                          {"GREEN_ON": True, "RED": 0.5})
    assert green is not first and cache.compile_count == 2
    cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl", {"RED": 0.5, "GREEN_ON": True})
    assert cache.compile_count == 2 and len(cache) == 2
    cache.clear()
    assert len(cache) == 0
    cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl", {"RED": 0.5})
    assert cache.compile_count == 3


def test_defines_change_what_the_program_draws(ctx):
    cache = ProgramCache()
    target = Image.empty(ctx, (4, 3))
    for defines, expected in [({"RED": 0.25}, (0.25, 0, 0, 1)),
                              ({"RED": 0.75, "GREEN_ON": True}, (0.75, 1, 0, 1))]:
        fullscreen_pass(ctx, cache.program(ctx, FULLSCREEN_VERTEX_SHADER, "defines.frag.glsl",
                                           defines), target)
        assert np.allclose(target.to_numpy(), expected)
    target.release()


# ---------------------------------------------------------------------------- passes

def test_fullscreen_pass_writes_uv_with_v_up(ctx):
    width, height = 8, 5
    target = Image.empty(ctx, (width, height))
    program = ProgramCache().program(ctx, FULLSCREEN_VERTEX_SHADER, "uv.frag.glsl")
    fullscreen_pass(ctx, program, target, uniforms={"optimised_away": 1.0})
    pixels = target.to_numpy()
    # pixel centres: u = (x + 0.5) / w; row 0 of the array is the top, where v is near 1
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    assert np.allclose(pixels[..., 0], u[None, :], atol=1e-6)
    assert np.allclose(pixels[..., 1], v[:, None], atol=1e-6)
    assert np.allclose(pixels[0, 0], (0.5 / 8, 4.5 / 5, 0, 1), atol=1e-6)  # top-left
    assert np.allclose(pixels[-1, -1], (7.5 / 8, 0.5 / 5, 0, 1), atol=1e-6)  # bottom-right
    target.release()


def test_fullscreen_pass_binds_textures_and_uniforms(ctx):
    source = np.random.default_rng(1).random((6, 7, 4)).astype(np.float32)
    image = Image.from_numpy(ctx, source)
    target = Image.empty(ctx, image.size)
    program = ProgramCache().program(ctx, FULLSCREEN_VERTEX_SHADER, "sample.frag.glsl")
    matrix = np.diag([2.0, 1.0, 1.0, 1.0])
    matrix[0, 3] = 0.5  # row-major numpy: x' = 2 x + 0.5
    fullscreen_pass(ctx, program, target, textures={"unused_tex": image.texture, "source": image},
                    uniforms={"gain": np.float64(1.0), "colour_matrix": matrix})
    expected = source.copy()
    expected[..., 0] = 2 * source[..., 0] + 0.5 * source[..., 3]
    assert np.allclose(target.to_numpy(), expected, atol=1e-6)
    image.release()
    target.release()


# ---------------------------------------------------------------------------- context

def test_one_shared_context(ctx):
    assert gl_context.get_context() is ctx and gl_context.has_context()
    assert ctx.version_code >= 330
    gl_context.set_context(ctx)  # installing the installed context again changes nothing
    assert gl_context.get_context() is ctx


def test_replacing_and_releasing_contexts(ctx, monkeypatch):
    import moderngl

    # Work on a private copy of the module state so the shared context survives this test.
    forgotten = []
    monkeypatch.setattr(gl_context, "_context", None)
    monkeypatch.setattr(gl_context, "_owned", False)
    monkeypatch.setattr(gl_context, "_release_callbacks", [forgotten.append])
    try:
        created = gl_context.get_context()
        assert created is not ctx and gl_context.get_context() is created
        foreign = moderngl.create_context(standalone=True, backend="egl", require=330)
        gl_context.set_context(foreign)  # vgraph created 'created', so it releases it
        assert forgotten == [created] and isinstance(created.mglo, moderngl.InvalidObject)
        assert gl_context.get_context() is foreign
        gl_context.release_context()  # 'foreign' belongs to its owner: forgotten, not released
        assert forgotten == [created, foreign] and not gl_context.has_context()
        assert not isinstance(foreign.mglo, moderngl.InvalidObject)
        foreign.release()
    finally:
        ctx.__enter__()  # creating a standalone context made it current; make ours current again


def test_context_failure_message_names_packages(monkeypatch):
    import moderngl

    def refuse(**kwargs):
        raise Exception(f"no display for {kwargs.get('backend', 'default')}")

    monkeypatch.setattr(moderngl, "create_context", refuse)
    with pytest.raises(VGraphError) as info:
        gl_context._create_standalone_context()
    text = str(info.value)
    assert "'egl'" in text and "'default'" in text and "libegl1" in text and "libgl1-mesa-dri" in text


# --- explicit binding: textures by name, strict uniforms ---------------------------------------------
def test_a_misspelt_uniform_is_an_error_naming_it_and_the_shader(ctx):
    from vgraph.gl.passes import set_uniform
    from vgraph.gl.shaders import programs
    program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, "grayscale.frag.glsl")
    assert set_uniform(program, "saturation", 0.5)
    with pytest.raises(ShaderError, match=r"grayscale\.frag\.glsl: no uniform 'saturaton' is declared"):
        set_uniform(program, "saturaton", 0.5)
    assert not set_uniform(program, "saturaton", 0.5, optional=True)  # marked optional: skipped


def test_textures_get_units_by_name(ctx):
    from vgraph.gl.passes import bind_textures
    from vgraph.gl.shaders import programs
    program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, "grayscale.frag.glsl")
    image = Image.empty(ctx, (2, 2))
    assert bind_textures(program, {"image": image}) == {"image": 0}
    with pytest.raises(ShaderError, match="no uniform 'picture'"):
        bind_textures(program, {"image": image, "picture": image})


def test_a_component_that_sets_an_undeclared_uniform_fails_the_evaluation(monkeypatch):
    """The ray casters set uniforms through their components: a typo there is an error naming it,
    never a silently wrong image."""
    from vgraph.errors import ProcessorError
    from vgraph.gl.raycasting.components import Background, Binding
    from vgraph.network import Network
    network = Network()
    network.add("FunctionSelector", id="f", resolution=16)
    network.add("EntryExitPoints", id="eep")
    network.add("RayCaster", id="rc")
    for a, b in (("f.volume", "eep.volume"), ("f.volume", "rc.volume"), ("eep.entry", "rc.entry"),
                 ("eep.exit", "rc.exit")):
        network.connect(a, b)
    monkeypatch.setattr(Background, "bind", lambda self, frame: Binding(uniforms={"backgrund": (0, 0, 0, 1)}))
    with pytest.raises(ProcessorError, match=r"processor 'rc' \(RayCaster\): .*raycaster\.frag\.glsl: no uniform 'backgrund'"):
        network.evaluate("rc.image", size=(8, 8))
