"""Atomic file writes: write to a temporary file beside the target, flush it to disk, then rename
it over the target, so a crash or an error halfway leaves the old file as it was."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path: str | Path, suffix: str | None = None):
    """Yield a temporary path in the target's folder; on success it replaces ``path``.
    ``suffix`` (default: the target's, e.g. '.nii.gz') lets writers that infer the format from the
    file name work on the temporary file."""
    path = Path(path)
    suffix = suffix if suffix is not None else "".join(path.suffixes)
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp" + suffix,
                                             dir=path.parent if str(path.parent) else ".")
    os.close(descriptor)
    temporary = Path(temporary)
    try:
        yield temporary
        with open(temporary, "rb+") as written:
            os.fsync(written.fileno())
        os.chmod(temporary, _mode_for(path))
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def _mode_for(target: Path) -> int:
    """mkstemp makes 0600 files: keep the target's mode, or what open() would have given."""
    try:
        return target.stat().st_mode & 0o777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_text_atomic(path: str | Path, text: str) -> None:
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
