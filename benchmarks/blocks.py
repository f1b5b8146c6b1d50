"""The generated blocks of the README and of docs/*.md: Markdown that a benchmark script writes
between two markers, never typed in.

    <!-- benchmark:start -->            the README's Results (run.py)
    ...
    <!-- benchmark:end -->

    <!-- benchmark:NAME:start -->       a block of a documentation page (docs.py), NAME such as
    ...                                 grid:numbers or demo:seeds; one pair per block
    <!-- benchmark:NAME:end -->

``replace_block`` is the one function that writes a block: it replaces what lies between the
block's two markers and nothing else, and refuses a text whose markers are missing, repeated or
out of order. ``problems`` lists what is wrong with the markers of a text (the tests run it on
every page).
"""

from __future__ import annotations

import re
from pathlib import Path

#: any marker: group 1 the block's name (None for the README's Results), group 2 start or end
MARKER = re.compile(r"<!-- benchmark(?::([A-Za-z0-9_.:-]+?))?:(start|end) -->")


class BlockError(ValueError):
    """A block's markers are missing, repeated or out of order."""


def markers(name: str | None = None) -> tuple[str, str]:
    """The start and end markers of block ``name`` (None: the README's Results block)."""
    tag = "benchmark" if name is None else f"benchmark:{name}"
    return f"<!-- {tag}:start -->", f"<!-- {tag}:end -->"


def replace_block(text: str, name: str | None, body: str) -> str:
    """``text`` with what lies between block ``name``'s markers replaced by ``body`` (one newline
    after the start marker, one before the end marker); everything else unchanged."""
    start, end = markers(name)
    if text.count(start) != 1 or text.count(end) != 1:
        raise BlockError(f"block {name or 'benchmark'}: expected one {start} and one {end}, found "
                         f"{text.count(start)} and {text.count(end)}")
    i = text.index(start) + len(start)
    j = text.index(end)
    if j < i:
        raise BlockError(f"block {name or 'benchmark'}: {end} comes before {start}")
    return text[:i] + "\n" + body.strip("\n") + "\n" + text[j:]


def write_block(path: str | Path, name: str | None, body: str) -> None:
    """Replace block ``name`` in the file at ``path`` (see ``replace_block``)."""
    path = Path(path)
    text = path.read_text()
    try:
        new = replace_block(text, name, body)
    except BlockError as e:
        raise BlockError(f"{path}: {e}") from None
    if new != text:
        path.write_text(new)


def names(text: str) -> list[str | None]:
    """The names of the blocks whose start marker ``text`` holds, in order."""
    return [m.group(1) for m in MARKER.finditer(text) if m.group(2) == "start"]


def problems(text: str) -> list[str]:
    """What is wrong with the markers of ``text``: a start without its end, an end without its
    start, a name used twice, or a block inside another. Empty when every block is well formed."""
    out, open_, seen = [], None, set()
    for m in MARKER.finditer(text):
        name, kind = m.group(1), m.group(2)
        label = name or "benchmark"
        line = text.count("\n", 0, m.start()) + 1
        if kind == "start":
            if open_ is not None:
                out.append(f"line {line}: block {label} starts inside block {open_[0] or 'benchmark'}")
            if name in seen:
                out.append(f"line {line}: block {label} appears twice")
            seen.add(name)
            open_ = (name, line)
        elif open_ is None or open_[0] != name:
            out.append(f"line {line}: block {label} ends without a start")
        else:
            open_ = None
    if open_ is not None:
        out.append(f"line {open_[1]}: block {open_[0] or 'benchmark'} has no end")
    return out


def demote_headings(md: str) -> str:
    """A script's own ## and ### headings as bold lines, so that a block adds no heading to the page."""
    return re.sub(r"^#{2,3} (.+)$", r"**\1**", md, flags=re.M).strip()
