"""How deeply JSON from a user may nest: a network file, a transfer-function file, a ``--set``
value. The deepest legitimate value (a camera in a property of a processor in a network) is 4
levels; 64 leaves room, and keeps Python's recursion (json, pydantic, deep copies) far from its
stack limit, which a 100 000-deep array reached."""

from __future__ import annotations

MAX_NESTING = 64


def nesting_depth(data) -> int:
    """How deeply lists and objects nest in ``data`` (a scalar is 0), without recursion; stops
    counting past MAX_NESTING."""
    deepest, stack = 0, [(data, 1)]
    while stack:
        value, depth = stack.pop()
        children = value.values() if isinstance(value, dict) else value if isinstance(value, list) else None
        if children is None:
            continue
        deepest = max(deepest, depth)
        if depth > MAX_NESTING:
            break
        stack.extend((child, depth + 1) for child in children)
    return deepest
