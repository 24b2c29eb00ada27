"""Atomic file writes: write to a temporary file beside the target, flush it to disk, then rename
it over the target, so a crash or an error halfway leaves the old file as it was.

Temporary files are named ``.<target name>.<pid>.<random>.tmp<suffix>`` (the target's name cut
and tagged with a hash where that would pass NAME_MAX). A process killed halfway (kill -9, power
loss) cannot remove its own; the next write to the same target removes those whose process is
gone. Every failure of the operating system (missing or read-only folder, full disk, a folder
where the file should be, a name too long) becomes an ``OutputFileError`` naming the path.

The target's folder is resolved and opened once; the temporary file is created in it with
O_EXCL | O_NOFOLLOW (never through a link someone planted under its name) and renamed within it.
A write confined to folders (``inside``: a network file's writers, vgraph.write_paths) is checked
at that moment, not only when the network was loaded: the resolved folder must lie inside them,
so a symbolic link made in the network's folder since (a GUI left open for hours) is refused, not
followed; a target that is itself a link pointing outside them is refused too, and folders are
created one at a time, each checked before it is made.
"""

from __future__ import annotations

import hashlib
import os
import re
import secrets
import shutil
import stat
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from vgraph.errors import OutputFileError
from vgraph.file_names import NAME_MAX, file_name_problem, shown

_DIR_FD = os.open in os.supports_dir_fd and os.rename in os.supports_dir_fd  # replace takes them too
_CREATE = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
_TRIES = 100  # names taken (by a planted link, say) before giving up, as tempfile.mkstemp
_SUFFIX_ROOM = 50  # bytes of the target's suffixes a temporary name repeats


@contextmanager
def atomic_path(path: str | Path, suffix: str | None = None, inside=None):
    """Yield a temporary path in the target's folder; on success it replaces ``path``.
    ``suffix`` (default: the target's, e.g. '.nii.gz') lets writers that infer the format from the
    file name work on the temporary file. ``inside``: folders the write must stay in (None: any)."""
    path = check_output_path(path)
    suffix = suffix if suffix is not None else _format_suffix(path)
    with _opened_folder(path, inside) as folder:
        remove_stale_temporaries(folder.path / path.name)
        name, descriptor = _create_temporary(folder, path, suffix)
        try:
            yield folder.path / name
            folder.check_still_holds(name, descriptor, path)
            os.fsync(descriptor)
            os.fchmod(descriptor, _mode_for(folder, path.name))
            _refuse_link_out(folder, path, inside)  # again: it may have appeared while writing
            folder.replace(name, path.name)
        except OSError as error:
            folder.unlink(name)
            raise OutputFileError(path, _reason(error)) from error
        except BaseException:
            folder.unlink(name)
            raise
        finally:
            os.close(descriptor)


def check_output_path(path: str | Path, create_folder: bool = False, inside=None) -> Path:
    """``path`` if a file can be written there: a name the system takes, its folder exists (or is
    created with ``create_folder``, each new folder inside ``inside`` when given) and it is not
    itself a folder. Raises OutputFileError naming the path."""
    problem = file_name_problem(str(path))
    if problem is not None:
        raise OutputFileError(_printable(path), problem)
    path = Path(path)
    if not path.name:
        raise OutputFileError(path, "names a folder, not a file")
    folder = path.parent
    try:
        if create_folder:
            make_folders(folder, inside)
        if not folder.is_dir():
            raise OutputFileError(path, f"the folder {str(folder)!r} does not exist")
        if path.is_dir():
            raise OutputFileError(path, "is a folder; give a file name")
    except OSError as error:  # a loop of links, a name the joined path makes too long
        raise OutputFileError(path, _reason(error)) from None
    return path


def make_folders(folder: Path, inside=None) -> None:
    """``mkdir -p folder``; with ``inside``, each folder made only where it lands inside those
    folders once its parent is resolved (a link made on the way is not followed out)."""
    if inside is None:
        folder.mkdir(parents=True, exist_ok=True)
        return
    missing = []
    while not os.path.lexists(folder) and folder != folder.parent:
        missing.append(folder.name)
        folder = folder.parent
    for name in reversed(missing):
        folder = folder.resolve() / name  # what is made: inside, whatever links led there
        _check_inside(folder, inside, folder)
        try:
            folder.mkdir()
        except FileExistsError:
            pass  # made meanwhile (or '..'): resolved and checked at the next step or the write


def remove_stale_temporaries(path: Path) -> None:
    """Remove temporary files (or folders: ``vgraph convert`` writes a store as one) of earlier
    writes to ``path`` whose writing process is gone."""
    pattern = re.compile(rf"^\.{re.escape(_temporary_stem(path.name))}\.(\d+)\.[^.]+\.tmp")
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


def _format_suffix(path: Path) -> str:
    """The suffixes that may tell a writer the format ('.nii.gz'); a name with dots all along
    ('run.2024.11.27.scan.nrrd') gives its last suffix only, so the temporary name stays short."""
    whole = "".join(path.suffixes)
    if len(os.fsencode(whole)) <= _SUFFIX_ROOM:
        return whole
    return path.suffix if len(os.fsencode(path.suffix)) <= _SUFFIX_ROOM else ""


def _temporary_stem(name: str) -> str:
    """The target's name as temporaries carry it: whole, or (beyond what leaves room for the
    rest under NAME_MAX) cut and tagged with a hash of it, so that it stays unique."""
    encoded = os.fsencode(name)
    room = NAME_MAX - 30 - _SUFFIX_ROOM  # '.' + '.<pid>.<random>.tmp' + the suffix
    if len(encoded) <= room:
        return name
    tag = hashlib.sha256(encoded).hexdigest()[:12]
    return os.fsdecode(encoded[:room - 13]) + "~" + tag  # any bytes: fsencode gives them back


@dataclass
class _Folder:
    """The target's folder, resolved and (where the system allows) held open: every operation on
    the temporary file goes through the descriptor, so the folder checked is the folder written."""
    path: Path
    descriptor: int | None

    def at(self, name: str) -> dict:
        return {"dir_fd": self.descriptor} if self.descriptor is not None else {}

    def name_path(self, name: str) -> str | Path:
        return name if self.descriptor is not None else self.path / name

    def check_still_holds(self, name: str, descriptor: int, target: Path) -> None:
        """The temporary name still is the file created (not replaced, by a link say), and the
        folder's path still leads to the folder held."""
        ours = os.fstat(descriptor)
        there = os.stat(self.name_path(name), **self.at(name), follow_symlinks=False)
        moved = self.descriptor is not None and not _same(os.stat(self.path), os.fstat(self.descriptor))
        if not _same(ours, there) or moved:
            raise OutputFileError(target, f"the temporary file or its folder {str(self.path)!r} was "
                                          f"replaced while writing; nothing was written")

    def replace(self, name: str, target: str) -> None:
        if self.descriptor is None:
            os.replace(self.path / name, self.path / target)
        else:
            os.replace(name, target, src_dir_fd=self.descriptor, dst_dir_fd=self.descriptor)

    def unlink(self, name: str) -> None:
        try:
            os.unlink(self.name_path(name), **self.at(name))
        except OSError:
            pass


def _same(a: os.stat_result, b: os.stat_result) -> bool:
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


@contextmanager
def _opened_folder(path: Path, inside):
    try:
        resolved = path.parent.resolve()
        descriptor = os.open(resolved, os.O_RDONLY | os.O_DIRECTORY) if _DIR_FD else None
    except OSError as error:
        raise OutputFileError(path, _reason(error)) from None
    try:
        folder = _Folder(_held_path(resolved, descriptor), descriptor)
        _check_inside(folder.path, inside, path)
        _refuse_link_out(folder, path, inside)
        yield folder
    finally:
        if descriptor is not None:
            os.close(descriptor)


def _held_path(resolved: Path, descriptor: int | None) -> Path:
    """Where the folder held open is (Linux says through /proc, whatever happened to the path
    since it was resolved); the resolved path elsewhere."""
    try:
        return Path(os.readlink(f"/proc/self/fd/{descriptor}")) if descriptor is not None else resolved
    except OSError:
        return resolved


def _check_inside(folder: Path, inside, target: Path) -> None:
    if inside is None or any(folder == allowed or folder.is_relative_to(allowed) for allowed in inside):
        return
    raise OutputFileError(target, f"its folder resolves to {folder}, outside the folders this network "
                                  f"may write into ({', '.join(map(str, inside))}): a symbolic link "
                                  f"made since the network was loaded? Nothing was written")


def _refuse_link_out(folder: _Folder, target: Path, inside) -> None:
    """A target that is a symbolic link pointing outside ``inside`` is not replaced: the user may
    have meant the file it points to, which this write may not touch."""
    if inside is None:
        return
    try:
        info = os.stat(folder.name_path(target.name), **folder.at(target.name), follow_symlinks=False)
    except FileNotFoundError:
        return
    except OSError as error:
        raise OutputFileError(target, _reason(error)) from None
    if stat.S_ISLNK(info.st_mode):
        pointed = (folder.path / target.name).resolve()
        _check_inside(pointed.parent, inside, target)


def _create_temporary(folder: _Folder, target: Path, suffix: str) -> tuple[str, int]:
    stem = f".{_temporary_stem(target.name)}.{os.getpid()}."
    for _ in range(_TRIES):
        name = f"{stem}{secrets.token_hex(4)}.tmp{suffix}"
        try:
            return name, os.open(folder.name_path(name), _CREATE, 0o600, **folder.at(name))
        except FileExistsError:
            continue  # taken (a file, or a link planted there): another name
        except OSError as error:
            raise OutputFileError(target, _reason(error)) from None
    raise OutputFileError(target, f"no free temporary name in {folder.path} after {_TRIES} tries")


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


def _printable(path) -> str:
    """A refused path as a message shows it: NUL escaped, an absurd length cut short."""
    text = str(path)
    return text.replace("\0", "\\0") if len(text) <= 200 else shown(text, 200)


def _mode_for(folder: _Folder, name: str) -> int:
    """The temporary file is 0600: keep the target's mode, or what open() would have given."""
    try:
        return os.stat(folder.name_path(name), **folder.at(name)).st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_text_atomic(path: str | Path, text: str) -> None:
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
