#!/usr/bin/env bash
# Fetches, here (where pip and apt reach their registries), what bench/gpu/run.sh needs on a GPU
# machine that has no network: cp312 manylinux wheels of vgraph's needs that machine's python3 lacks
# (bench/gpu/wheels/), the EGL loader packages as .deb files (bench/gpu/debs/) and copies of the
# data sets the networks read (bench/gpu/data/). All three are ignored by git (.gitignore) and
# travel as the `run` tool's carry (docs/reports/performance.md, "Real GPU numbers").
#
#     bench/gpu/prepare.sh            # then: bench/gpu/run.sh --dry-run  (here, llvmpipe)
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
PYTHON=${PYTHON:-$ROOT/.venv/bin/python}
SHARED=${SHARED:-$ROOT/../shared/data}
cd "$HERE"

# The versions installed in the venv (the ones the tests pass with), cp312 builds of them.
version() { "$PYTHON" -c "import importlib.metadata as m, sys; print(m.version(sys.argv[1]))" "$1"; }
WHEELS=(moderngl glcontext pydantic pydantic_core PyOpenGL pynrrd nibabel pydicom meshio tqdm zarr numcodecs
        dask distributed)
# scikit-image is imported by the IsoSurfaceExtractor (every built-in processor is imported); its own
# needs numpy, scipy, networkx and pillow are on the machine already, so no resolution for it.
NO_DEPS=(scikit-image imageio tifffile lazy-loader)
pinned() { for name in "$@"; do echo "$name==$(version "$name")"; done; }
PLATFORM=(--only-binary=:all: --python-version 3.12 --implementation cp --platform manylinux_2_28_x86_64
          --platform manylinux_2_24_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64
          --platform manylinux1_x86_64 -d wheels)
mkdir -p wheels
"$PYTHON" -m pip download -q "${PLATFORM[@]}" $(pinned "${WHEELS[@]}")
"$PYTHON" -m pip download -q --no-deps "${PLATFORM[@]}" $(pinned "${NO_DEPS[@]}")
rm -f wheels/numpy-*.whl  # the machine's own numpy stays (scipy and numba there are built against it)

# The EGL loaders (glvnd); the NVIDIA vendor library itself is on the machine (device README).
mkdir -p debs /tmp/amd64/partial
apt=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64)
apt-get "${apt[@]}" update -qq
(cd debs && apt-get "${apt[@]}" download -qq libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)

# The shipped networks read ../../shared/data/<set>/...; bench_distributed reads the bonsai and engine.
mkdir -p data
for set in ct_bonsai ct_engine ct_head_headsq hex_disk_out_ref tet_lox_post; do
    cp -r "$SHARED/$set" data/
done
chmod -R u+w data
du -sh wheels debs data
