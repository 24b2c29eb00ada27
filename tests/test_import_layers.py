"""The contracts of pyproject.toml's [tool.importlinter] hold: lower layers never import higher ones
(the model, then rendering, files and numerics, then the processors, then the applications), the
render side imports no Qt, and no package has an import circle inside (docs/architecture.md,
"Layers").

import-linter finds a package's modules by walking its folder. The built-in processors and the
GLSL live beside src/vgraph and install as vgraph.processors and vgraph.shaders (pyproject's
package-dir); an editable install maps them by name, so a walk of src/vgraph would not see them,
nor any import of them. The test therefore lints a folder laid out as the installed package: a
``vgraph`` of links to src/vgraph's entries, processors/ and shaders/, found first on the path
of a fresh interpreter (this one has imported vgraph from src/vgraph already).
"""

import os
import subprocess
import sys

from helpers.paths import REPO

LINT = ("import sys; from importlinter.cli import lint_imports; "
        "sys.exit(lint_imports(config_filename='pyproject.toml', no_cache=True, no_logo=True))")


def installed_layout(folder):
    """A ``vgraph`` package in ``folder`` as an install lays it out, made of links to the sources."""
    package = folder / "vgraph"
    package.mkdir()
    for entry in (REPO / "src" / "vgraph").iterdir():
        if entry.name != "__pycache__":
            (package / entry.name).symlink_to(entry)
    (package / "processors").symlink_to(REPO / "processors")
    (package / "shaders").symlink_to(REPO / "shaders")
    return folder


def test_the_import_contracts_hold(tmp_path):
    environment = {**os.environ, "PYTHONPATH": str(installed_layout(tmp_path))}
    result = subprocess.run([sys.executable, "-c", LINT], cwd=REPO, env=environment,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "3 kept, 0 broken" in result.stdout  # every contract was read and checked
