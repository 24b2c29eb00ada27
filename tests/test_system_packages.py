"""The README names every system package .ci/run checks (issue 32, item 8): the headless set it
installs and the set a real window needs, which it names when missing; and that check only
warns (CI runs the GUI tests offscreen)."""

import re
import subprocess

from helpers.paths import REPO

CI = (REPO / ".ci" / "run").read_text()


def listed(variable: str) -> list[str]:
    return re.search(rf'^{variable}="([^"]+)"', CI, re.M).group(1).split()


def test_the_readme_names_every_package_ci_checks():
    readme = " ".join((REPO / "README.md").read_text().split())
    window = listed("window_packages")
    assert "libxcb-cursor0" in window and "libxcb-icccm4" in window and "libxcb-keysyms1" in window
    for package in listed("packages") + window:
        assert f"{package}" in readme, package


def test_missing_window_packages_are_a_warning_not_a_failure(tmp_path):
    """The window check of .ci/run, run on its own with a dpkg that knows no package."""
    start = CI.index("window_packages=")
    check = CI[start:CI.index("export QT_QPA_PLATFORM")]
    fake = tmp_path / "dpkg"
    fake.write_text("#!/bin/sh\nexit 1\n")
    fake.chmod(0o755)
    done = subprocess.run(["bash", "-euo", "pipefail", "-c", check], capture_output=True, text=True,
                          env={"PATH": f"{tmp_path}:/usr/bin:/bin"})
    assert done.returncode == 0
    assert "warning: a real window" in done.stdout and "libxcb-cursor0" in done.stdout
