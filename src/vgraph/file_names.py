"""What a string must be before it goes to the operating system as a file name.

A file path comes from a network file, ``--set``, a transfer-function name or an option, and
the system refuses some of them only when it is asked (``File name too long``, a NUL byte, text
that has no bytes in the file-system encoding). Each is refused here first, with a reason a
message can name beside its place (processor and property, JSON path, option):

- no NUL character;
- encodable in the file-system encoding (UTF-8 here): a lone surrogate such as ``\\ud800`` is not,
  while the ``\\udc80``-``\\udcff`` that Python makes of undecodable bytes in names stay those bytes;
- at most ``NAME_MAX`` bytes per component and ``PATH_MAX`` bytes in all, after encoding (the
  limits of Linux and most file systems; macOS allows less in all, never more per name).
"""

from __future__ import annotations

import os
from pathlib import Path

NAME_MAX = 255    # bytes in one file or folder name
PATH_MAX = 4096   # bytes in a whole path, terminating NUL included on Linux
SHOWN_CHARACTERS = 60  # of a refused name in a message: enough to recognise it


def file_name_problem(text: str) -> str | None:
    """Why ``text`` cannot be given to the system as a path, or None when it can."""
    if "\0" in text:
        return "a file path cannot contain a NUL byte"
    try:
        encoded = os.fsencode(text)
    except UnicodeEncodeError as error:
        return (f"a file path must be text this system can use as a file name ({error.reason} at "
                f"character {error.start})")
    if len(encoded) >= PATH_MAX:
        return f"a file path can be at most {PATH_MAX - 1} bytes, this one is {len(encoded)}"
    longest = max(encoded.split(b"/"), key=len)
    if len(longest) > NAME_MAX:
        name = shown(os.fsdecode(longest))
        return (f"a file or folder name can be at most {NAME_MAX} bytes, {name} is "
                f"{len(longest)}")
    return None


def check_file_name(text: str) -> str:
    """``text`` if it can be a path (see the module docstring); ValueError with the reason."""
    problem = file_name_problem(text)
    if problem is not None:
        raise ValueError(problem)
    return text


def expanded(path: str | Path) -> Path:
    """``path`` with a leading ``~`` or ``~user`` replaced by that home folder, as a shell does:
    left as it is when there is no such user (pathlib raises RuntimeError there) or the name
    cannot be looked up (a NUL, a surrogate: validation names those)."""
    try:
        return Path(os.path.expanduser(path))
    except (ValueError, KeyError):  # UnicodeEncodeError is a ValueError
        return Path(path)


def shown(text: str, limit: int = SHOWN_CHARACTERS) -> str:
    """``text`` quoted for a message: the repr (so a surrogate or a NUL shows as an escape, and the
    message prints everywhere), cut to ``limit`` characters with the full length said."""
    quoted = repr(text)
    if len(text) <= limit:
        return quoted
    return f"{repr(text[:limit])[:-1]}...' ({len(text)} characters)"
