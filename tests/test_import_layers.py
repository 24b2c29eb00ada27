"""The contracts of pyproject.toml's [tool.importlinter] hold: lower layers never import higher ones
(the model, then rendering, files and numerics, then the processors, then the applications), the
render side imports no Qt, and no package has an import circle inside (docs/explanations/architecture.md,
"Layers").

import-linter finds a package's modules by walking its folder. The built-in processors and the
GLSL live beside src/vgraph and install as vgraph.processors and vgraph.shaders (pyproject's
package-dir); src/vgraph/processors and src/vgraph/shaders are links to them, so that a walk of
src/vgraph sees the installed layout and a bare ``lint-imports`` checks every contract.
"""

import subprocess
import sys
import tomllib

from helpers.paths import REPO

LINT = ("import sys; from importlinter.cli import lint_imports; "
        "sys.exit(lint_imports(config_filename='pyproject.toml', no_cache=True, no_logo=True))")


def test_the_import_contracts_hold():
    result = subprocess.run([sys.executable, "-c", LINT], cwd=REPO, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    contracts = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    assert f"{len(contracts)} kept, 0 broken" in result.stdout  # every contract was read and checked


def test_no_contract_lists_exceptions():
    """A contract holds for every import: none is waved through by ``ignore_imports`` (or kept
    unchecked by ``unmatched_ignore_imports_alerting``)."""
    contracts = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    assert [(c["name"], key) for c in contracts for key in c if "ignore" in key] == []
