"""Atomic file writes: write to a temporary file beside the target, flush it to disk, then rename
it over the target, so a crash or an error halfway leaves the old file as it was.

Temporary files are named ``.<target name>.<pid>.<random>.tmp<suffix>``. A process killed halfway
(kill -9, power loss) cannot remove its own; the next write to the same target removes those whose
process is gone. Every failure of the operating system (missing or read-only folder, full disk, a
folder where the file should be) becomes an ``OutputFileError`` naming the path.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from vgraph.errors import OutputFileError


@contextmanager
def atomic_path(path: str | Path, suffix: str | None = None):
    """Yield a temporary path in the target's folder; on success it replaces ``path``.
    ``suffix`` (default: the target's, e.g. '.nii.gz') lets writers that infer the format from the
    file name work on the temporary file."""
    path = check_output_path(path)
    suffix = suffix if suffix is not None else "".join(path.suffixes)
    remove_stale_temporaries(path)
    try:
        descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.",
                                                 suffix=".tmp" + suffix, dir=path.parent)
    except OSError as error:
        raise OutputFileError(path, _reason(error)) from None
    os.close(descriptor)
    temporary = Path(temporary)
    try:
        yield temporary
        with open(temporary, "rb+") as written:
            os.fsync(written.fileno())
        os.chmod(temporary, _mode_for(path))
        os.replace(temporary, path)
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise OutputFileError(path, _reason(error)) from error
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def check_output_path(path: str | Path, create_folder: bool = False) -> Path:
    """``path`` if a file can be written there: its folder exists (or is created with
    ``create_folder``) and it is not itself a folder. Raises OutputFileError naming the path."""
    if "\0" in str(path):
        raise OutputFileError(str(path).replace("\0", "\\0"), "a file name cannot contain a NUL byte")
    path = Path(path)
    if not path.name:
        raise OutputFileError(path, "names a folder, not a file")
    folder = path.parent
    try:
        if create_folder:
            folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputFileError(path, f"cannot create its folder: {_reason(error)}") from None
    if not folder.is_dir():
        raise OutputFileError(path, f"the folder {str(folder)!r} does not exist")
    if path.is_dir():
        raise OutputFileError(path, "is a folder; give a file name")
    return path


def remove_stale_temporaries(path: Path) -> None:
    """Remove temporary files (or folders: ``vgraph convert`` writes a store as one) of earlier
    writes to ``path`` whose writing process is gone."""
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.[^.]+\.tmp")
    try:
        candidates = list(path.parent.iterdir())
    except OSError:
        return
    for candidate in candidates:
        match = pattern.match(candidate.name)
        if match and not _process_alive(int(match.group(1))):
            if candidate.is_dir() and not candidate.is_symlink():
                shutil.rmtree(candidate, ignore_errors=True)
                continue
            try:
                candidate.unlink()
            except OSError:
                pass  # someone else's file or a race: it is only clutter


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # it exists (another user's), or the number is not a pid: leave it
    return True


def _reason(error: OSError) -> str:
    return error.strerror or str(error)


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
