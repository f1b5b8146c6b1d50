"""Files for every format: outputs checked before a long command starts, every file written
atomically (the old file or the complete new one, never half) so that nothing already built is
lost, JSON read the same way everywhere, and maps read from a file checked."""

from __future__ import annotations

import glob
import json
import os
import re
import stat
import sys
import tempfile
from pathlib import Path

from ..brep import BRepMap, validate_map
from ..errors import GeometryError, MapFileError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: the permissions a plain open(path, "w") would give: temporary files start private (0600)
FILE_MODE = 0o666 & ~_umask()


#: the largest map file (JSON or compact) or point list read: a device such as /dev/zero, or a
#: FIFO, has no size to check first, so reading stops one byte past it (the largest real map,
#: Freiburg campus's, is a few MB)
MAX_INPUT_BYTES = 512 * 2**20


def read_limited(path: str | os.PathLike, limit: int | None = None, what: str = "a map file") -> bytes:
    """The bytes of a file, read to at most ``limit`` bytes: MapFileError naming the file when it
    cannot be read or holds more. A regular file's size is checked before it is read; anything else
    (a device, a FIFO, standard input) is read a chunk at a time and refused one byte past the limit,
    since its size (0) says nothing. ``limit`` None: MAX_INPUT_BYTES."""
    path = Path(path)
    limit = MAX_INPUT_BYTES if limit is None else limit
    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if stat.S_ISDIR(st.st_mode):
                raise IsADirectoryError(21, "Is a directory")
            if stat.S_ISREG(st.st_mode) and st.st_size > limit:
                raise MapFileError(path, f"the file is {st.st_size / 2**20:.0f} MiB; {what} is read up to "
                                         f"{limit / 2**20:g} MiB")
            chunks, total = [], 0
            while total <= limit:
                chunk = f.read(min(1 << 20, limit + 1 - total))
                if not chunk:
                    break
                chunks.append(chunk)
                total += len(chunk)
    except OSError as e:
        raise MapFileError(path, f"cannot read: {e.strerror or e}") from None
    if total > limit:
        raise MapFileError(path, f"more than {limit / 2**20:g} MiB (not a regular file, so read until then); "
                                 f"{what} is read up to {limit / 2**20:g} MiB")
    return b"".join(chunks)


def check_writable(path: str | os.PathLike) -> None:
    """MapFileError now if ``write_atomic(path, ...)`` cannot work because of where the path
    points: a folder, below a file, or in a folder that cannot be written. A command that works
    for a long time before it writes checks first, so that the work is not lost at the end."""
    if os.fspath(path).endswith(("/", os.sep)):
        # Path() drops the slash: "--html out/" wrote a file named "out" where a folder was meant
        raise MapFileError(path, "cannot write: the name ends with a slash, so it names a folder (give a file name)")
    path = Path(path)
    if path.is_dir():
        raise MapFileError(path, "cannot write: it is a folder (give a file name)")
    kind = _not_a_file(path)
    if kind:
        raise MapFileError(path, f"cannot write: it is {kind}, not a regular file, and writing would replace it "
                                 f"(give a file name)")
    path = _target(path)
    folder = path.parent
    while not folder.exists() and folder != folder.parent:  # write_atomic creates the missing ones
        folder = folder.parent
    if not folder.is_dir():
        raise MapFileError(path, f"cannot write: {folder} is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):  # also false on a read-only file system, even for root
        raise MapFileError(path, f"cannot write: folder {folder} is not writable")


def check_outputs(*paths: str | os.PathLike | None, inputs: tuple) -> None:
    """``check_writable`` for every output a command was given (None: not asked for), before it
    writes any: a command whose last output cannot be written must not leave the first ones.

    An output that is one of ``inputs``, or that is given twice, is refused as well: a slip of the
    keyboard (``build run.log --out run.log``) must not replace the log being read by the map, nor
    one output by another. An input folder (a ROS 2 bag) stands for every file in it: an output
    that is a file inside it (``build BAG --out BAG/metadata.yaml``), or a hard link to a file
    directly in it, is refused; one of a bag's files given as the input (``BAG/metadata.yaml``,
    ``BAG/BAG_0.db3``) stands for its folder, since the whole bag is read. A new name inside an
    input folder replaces nothing and is written. ``inputs`` has no default, so that no caller forgets it (``tables
    --csv DIR`` did, and replaced a map named DIR/vertices_principal.csv). Linear in the number of paths (``tables --csv`` checks one per ring:
    pairwise, 6000 tables took ten minutes)."""
    given = [p for p in paths if p is not None]
    for p in given:
        check_writable(p)  # as given: a trailing slash says a folder was meant
    # every identity of a file seen so far -> ("input", path), ("folder", path, folder), ("output", path)
    names: dict = {}
    folders: list[tuple[Path, str | os.PathLike]] = []  # input folders, resolved, and the input given
    for q in inputs:
        if q is not None:
            for key in _identities(q):
                names.setdefault(key, ("input", q))
            folder = _input_folder(q)
            if folder is not None:
                folders.append((folder, q))
                for key in _folder_identities(folder):
                    names.setdefault(key, ("folder", q, folder))
    for p in map(Path, given):
        keys = _identities(p)
        seen = next((names[k] for k in keys if k in names), None)
        if seen is None and p.exists():  # a file deeper in an input folder, by its path
            seen = next((("folder", q, f) for f, q in folders for k in keys
                         if k[0] == "path" and k[1].is_relative_to(f)), None)
        if seen is not None and seen[0] == "input":
            raise MapFileError(p, f"cannot write: it is the input {seen[1]} as well, which writing would replace; "
                                  f"give another name")
        if seen is not None and seen[0] == "folder":
            raise MapFileError(p, f"cannot write: it is a file of the input {seen[1]} (the folder {seen[2]}), which "
                                  f"writing would replace; give another name")
        if seen is not None:
            raise MapFileError(p, "cannot write: it is given for two outputs, and the second would replace the first")
        for k in keys:
            names[k] = ("output", p)


def _identities(path: str | os.PathLike) -> list:
    """What names one file, whichever way a path spells it: its resolved path, and for a file that
    exists its device and inode (also through hard links). Nothing for a path that cannot be
    resolved (a loop of links): not provably the same as any other."""
    path = Path(path)
    try:
        keys: list = [("path", path.resolve())]
        if path.exists():
            st = path.stat()
            keys.append(("inode", st.st_dev, st.st_ino))
        return keys
    except (OSError, RuntimeError):
        return []


#: the most entries of an input folder whose files are compared with the outputs by inode (a ROS 2
#: bag holds a few); beyond, a file in it is still found by its path
MAX_FOLDER_ENTRIES = 10000
#: what a ROS 2 bag folder holds that names the folder: scans.rosbag reads the whole bag for any
_BAG_FILES = (".db3", ".mcap")


def _input_folder(path: str | os.PathLike) -> Path | None:
    """The folder an input stands for, resolved: itself if a folder, a ROS 2 bag's folder for one
    of its files (``metadata.yaml`` beside it); None otherwise."""
    path = Path(path)
    try:
        if path.is_dir():
            return path.resolve()
        if (path.suffix in _BAG_FILES or path.name == "metadata.yaml") and (path.parent / "metadata.yaml").is_file():
            return path.parent.resolve()
    except (OSError, RuntimeError):
        pass
    return None


def _folder_identities(folder: Path) -> list:
    """The device and inode of each file directly in a folder (the first MAX_FOLDER_ENTRIES)."""
    keys = []
    try:
        with os.scandir(folder) as it:
            for k, entry in enumerate(it):
                if k >= MAX_FOLDER_ENTRIES:
                    break
                try:
                    st = entry.stat()
                except OSError:
                    continue
                if stat.S_ISREG(st.st_mode):
                    keys.append(("inode", st.st_dev, st.st_ino))
    except OSError:
        pass
    return keys


_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder"))


def _not_a_file(path: Path) -> str | None:
    """What an existing output path is when it is no regular file (through symbolic links): a
    device, a FIFO, a socket, a folder; None for a regular file or a new name. Renaming over such
    a path would replace it (as root, ``--out /dev/null`` replaced the system's /dev/null)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


def _target(path: Path) -> Path:
    """Where writing ``path`` goes: the file a symbolic link points to (through every link, made
    absolute), created if the link dangles, so that the link stays a link; ``path`` itself if it
    is none. MapFileError for a loop of links."""
    if not path.is_symlink():
        return path
    target = Path(os.path.realpath(path))
    if target.is_symlink():  # realpath stops where the links go round in a loop
        raise MapFileError(path, "cannot write: it is a symbolic link in a loop of links")
    return target


def write_atomic(path: str | os.PathLike, data: bytes) -> int:
    """Write bytes so that the file is either the old one or the complete new one, never half.

    The bytes go to a temporary file beside it, ``.NAME.PID.XXXXXXXX.tmp``, which then replaces
    it. A file being replaced keeps its permissions (a private 0600 map stayed private; it was
    reset to 0644); a new one gets those of ``open(path, "w")``. A writer killed before the rename
    leaves its temporary file behind: the next write of the same name removes every one whose
    writer (PID) is no longer running on this machine (``_remove_stale``).

    An output that exists and is no regular file (a device such as /dev/null, a FIFO, a folder) is
    refused: MapFileError. A symbolic link is written through: its target is replaced atomically
    (a dangling link's target is created) and the link stays."""
    path = Path(path)
    check_writable(path)
    path = _target(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale(path)
        try:
            st = os.stat(path)
            mode = stat.S_IMODE(st.st_mode) if stat.S_ISREG(st.st_mode) else FILE_MODE
        except OSError:
            mode = FILE_MODE
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
        try:
            os.fchmod(fd, mode)
            with os.fdopen(fd, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError as e:
        raise MapFileError(path, f"cannot write: {e.strerror or e}") from None
    return len(data)


def _remove_stale(path: Path) -> None:
    """Remove the temporary files of ``write_atomic(path)`` left by writers that were killed:
    those whose PID no longer runs. A live writer's file is left alone, and so is any other
    file (one without a PID in its name is not ours to judge), and anything named so that is not
    a regular file (a folder, a link: we write only regular files). Nothing here stops the write:
    the new temporary file gets a name of its own (``mkstemp``) whatever is left beside it."""
    prefix = f".{path.name}."
    for tmp in path.parent.glob(glob.escape(prefix) + "*.tmp"):
        pid = tmp.name[len(prefix):].split(".", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _running(int(pid)):
            try:
                if stat.S_ISREG(tmp.lstat().st_mode):  # before: a folder so named was "Is a directory"
                    tmp.unlink()
            except OSError:
                pass  # gone already, or not ours to remove: the write goes on


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True  # someone else's, or not a PID we can ask about: keep its file
    return True


def check_map(crisp: BRepMap, path: str | os.PathLike) -> None:
    """MapFileError naming the file, ring and vertex if a map read from ``path`` has a degenerate
    or self-intersecting ring (the sweep and every α-cut need simple rings)."""
    try:
        validate_map(crisp)
    except GeometryError as e:
        raise MapFileError(path, str(e)) from None


def _json_integer(text: str) -> int | float:
    """A JSON integer, or ±inf when it is too large for a float, as a JSON real that large
    (1e400) already reads: every reader then refuses it as not finite, naming the place. Kept as
    an int, it failed deep inside a reader (OverflowError on the way to a float, or Python's
    ValueError for an integer of more than 4300 digits)."""
    if len(text.lstrip("-")) <= 308:  # the largest float has 309 digits: a shorter integer fits
        return int(text)
    return float(text)  # float() parses any length: inf beyond the largest float


class JSONLimitError(json.JSONDecodeError):
    """JSON that parses, or would, but that no reader of ours can take: nested too deeply for
    Python's parser, or a string holding a lone UTF-16 surrogate (``"\\ud800"``), which is no text
    and fails every later write (UnicodeEncodeError in ``view`` and ``export``). A JSONDecodeError,
    so that every reader's "not valid JSON (...)" names the file."""

    def __init__(self, message: str, doc: str = "", pos: int = 0):
        ValueError.__init__(self, message)
        self.msg, self.doc, self.pos, self.lineno, self.colno = message, doc, pos, 1, pos + 1


#: a \uD800-\uDFFF escape: a surrogate, lone unless its pair follows; only files holding one are
#: searched for a lone one (the search walks every string)
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F][0-9a-fA-F]{2}")
_SURROGATE_ESCAPE_BYTES = re.compile(_SURROGATE_ESCAPE.pattern.encode())


def _lone_surrogate(obj) -> str | None:
    """The first string (key or value) in a parsed JSON document that holds a lone surrogate."""
    stack = [obj]
    while stack:
        o = stack.pop()
        if isinstance(o, dict):
            stack.extend(o.keys())
            stack.extend(o.values())
        elif isinstance(o, list):
            stack.extend(o)
        elif isinstance(o, str):
            try:
                o.encode("utf-8")
            except UnicodeEncodeError:
                return o
    return None


def loads_json(raw: str | bytes):
    """``json.loads`` for the files fuzzybrep reads: integers too large for a float read as ±inf;
    JSONLimitError (a JSONDecodeError) for nesting deeper than Python's parser goes (about 1000
    levels: a RecursionError before) and for a string with a lone surrogate."""
    try:
        obj = json.loads(raw, parse_int=_json_integer)
    except RecursionError:
        raise JSONLimitError(f"nested more than {sys.getrecursionlimit()} levels deep, "
                             f"beyond what the JSON parser reads") from None
    if (_SURROGATE_ESCAPE if isinstance(raw, str) else _SURROGATE_ESCAPE_BYTES).search(raw):
        bad = _lone_surrogate(obj)
        if bad is not None:
            shown = bad.encode("utf-8", "backslashreplace").decode()
            raise JSONLimitError(f"the string \"{shown[:60]}\" holds a lone UTF-16 surrogate, which is not text")
    return obj
