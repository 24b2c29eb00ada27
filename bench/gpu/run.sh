#!/usr/bin/env bash
# vgraph's numbers on a GPU machine with no network (issue 31, item 5; docs/reports/performance.md,
# "Real GPU numbers"). Needs bench/gpu/prepare.sh's wheels/, debs/ and data/ beside it (carried).
#
#     bench/gpu/run.sh                          # there: unpack the EGL loaders, install the wheels, measure
#     bench/gpu/run.sh --dry-run [--write-refs] # here: the same flow on llvmpipe at tiny sizes
#
# Arguments go to measure.py; the table lands in $OUT (else bench/results/gpu).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
dry=0
for arg in "$@"; do [ "$arg" = --dry-run ] && dry=1; done
if [ $dry = 1 ]; then
    PYTHON=${PYTHON:-$ROOT/.venv/bin/python}
else
    PYTHON=python3
    for f in "$HERE"/debs/*.deb; do dpkg -x "$f" /; done  # glvnd's libEGL (device README)
    ldconfig
    vendor=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
    if [ -f $vendor ]; then export __EGL_VENDOR_LIBRARY_FILENAMES=$vendor; fi
    site=/tmp/vgraph-gpu-site
    "$PYTHON" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target $site \
        "$HERE"/wheels/*.whl
    export PYTHONPATH=$site
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
fi
# vgraph travels as the working tree: src/vgraph/processors and src/vgraph/shaders link to the folders.
export PYTHONPATH=$ROOT/src${PYTHONPATH:+:$PYTHONPATH}
export PYTHONUNBUFFERED=1
exec "$PYTHON" "$HERE/measure.py" "$@"
