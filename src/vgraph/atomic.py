"""Atomic file writes: write to a temporary file beside the target, then rename over it, so a
crash or an error halfway leaves the old file as it was."""

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
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=suffix or ".tmp",
                                             dir=path.parent if str(path.parent) else ".")
    os.close(descriptor)
    try:
        yield Path(temporary)
        os.chmod(temporary, 0o666 & ~_umask())  # mkstemp makes 0600; give the file normal rights
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def write_text_atomic(path: str | Path, text: str) -> None:
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
