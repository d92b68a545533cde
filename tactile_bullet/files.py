"""Writing files so that nothing is ever half-written, and numpy values as plain JSON.

Every output of the project (records, models, reports, figures, dataset shards and
manifests) goes through :func:`atomic_path`: the data is written to a temporary file next to
the target and renamed over it only once complete, so a crash or a full disk leaves the old
file (or none), never a truncated one.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .errors import UsageError


@contextlib.contextmanager
def atomic_path(
    path: str | os.PathLike, what: str = "file", durable: bool = False
) -> Iterator[Path]:
    """A temporary path to write; renamed over ``path`` when the block ends without error.

    The temporary name keeps the suffix (matplotlib picks the format from it) and carries the
    process id (parallel writers never share one). ``durable`` also fsyncs the file and its
    folder, for data that must survive a power cut (dataset shards and manifests). An OSError
    becomes a UsageError naming ``what`` and the path.
    """
    path = Path(path)
    refuse_special(path, what)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        if durable:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
        if durable:
            _fsync_dir(path.parent)
        if path.absolute() in _PLANNED:
            note_written(path)
    except OSError as exc:
        raise UsageError(f"cannot write {what} {path}: {exc.strerror or exc}") from None
    finally:
        tmp.unlink(missing_ok=True)


_SPECIAL = (
    (stat.S_ISLNK, "a symbolic link"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
)


def refuse_special(path: str | os.PathLike, what: str = "output") -> None:
    """Refuse an existing ``path`` that is not a regular file or a folder: renaming a new file
    over a device, FIFO, socket or symbolic link would replace the node itself (``/dev/null``
    run as root becomes a regular file; a link stops pointing where the user keeps the data),
    which ``--force`` never means."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        raise UsageError(f"cannot inspect {what} {path}: {exc.strerror or exc}") from None
    for test, kind in _SPECIAL:
        if test(mode):
            raise UsageError(
                f"{what} {path} is {kind}, not a regular file: not replacing it "
                "(name a regular file or a new path)"
            )


def not_a_file(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot be read as a file ("does not exist", "is a folder", "is a FIFO,
    not a regular file", ...), or None for a regular file (links followed): an input that is
    there but of the wrong kind is never reported as missing."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "does not exist"
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    kind = next((k for test, k in _SPECIAL if test(mode)), "a special file")
    return f"is {kind}, not a regular file"


def write_bytes_atomic(
    path: str | os.PathLike, data: bytes, what: str = "file", durable: bool = False
) -> Path:
    with atomic_path(path, what, durable) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


LEDGER = ".tactile-bullet-written.json"
"""In a folder a command writes several named files into (a report, figures, example objects),
the sha256 of each file as this project wrote it. ``--force`` replaces only a file the ledger
vouches for: one it never wrote, or one changed since (a user's notes saved under the same name,
an edited figure), is refused by name."""
_PLANNED: set[Path] = set()
"""Files :func:`existing_outputs` cleared for writing in this process: :func:`atomic_path` adds
each to its folder's ledger once written."""


def _sha256(path: Path) -> str | None:
    import hashlib

    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            while block := fh.read(1 << 20):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()


def _ledger(folder: Path) -> dict[str, str]:
    import json

    try:
        doc = json.loads((folder / LEDGER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    files = doc.get("files") if isinstance(doc, dict) else None
    return {str(k): str(v) for k, v in files.items()} if isinstance(files, dict) else {}


def vouched(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a file this project wrote, unchanged since (its folder's ledger)."""
    path = Path(path)
    digest = _ledger(path.parent).get(path.name)
    return digest is not None and _sha256(path) == digest


def note_written(path: str | os.PathLike) -> None:
    """Add ``path`` (just written) to its folder's ledger; a ledger that cannot be written
    costs only the right to replace the file later with ``--force``."""
    import json

    path = Path(path)
    files = _ledger(path.parent)
    digest = _sha256(path)
    if digest is None:
        return
    files[path.name] = digest
    tmp = path.parent / f".{LEDGER}.{os.getpid()}.tmp"
    try:
        tmp.write_text(json.dumps({"written_by": "tactile-bullet", "files": files}, indent=1,
                                  sort_keys=True), encoding="utf-8")  # fmt: skip
        os.replace(tmp, path.parent / LEDGER)
    except OSError:
        tmp.unlink(missing_ok=True)


def existing_outputs(
    folder: str | os.PathLike, names: Iterable[str], what: str, force: bool
) -> None:
    """Refuse (unless ``force``) a folder that already holds any of the files a command would
    write there: an earlier report or figure is kept unless the user asks otherwise. With
    ``force``, only files this project wrote there and nobody changed since (:data:`LEDGER`)
    are replaced; any other is refused by name, before any work."""
    folder = Path(folder)
    names = list(names)
    _PLANNED.update((folder / n).absolute() for n in names)
    if not folder.is_dir():
        return
    for name in names:
        refuse_special(folder / name, what)
    found = sorted(n for n in names if (folder / n).exists())
    if found and not force:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise UsageError(
            f"{what} {folder} already holds {found[0]}{more} from an earlier run; "
            "add --force to overwrite, or choose another folder"
        )
    foreign = [n for n in found if not vouched(folder / n)]
    if foreign:
        raise UsageError(
            f"{what} {folder} holds {foreign[0]}, which this project did not write there (or "
            "which changed since): --force replaces only its own files; move it away or "
            "choose another folder"
        )


def probe_folder(folder: str | os.PathLike, what: str) -> Path:
    """Create ``folder`` if needed and write (then remove) a small file in it: the one check
    that holds for every user, root included (``os.access`` says yes to root on a read-only
    mount), made before long work rather than found after it."""
    import tempfile

    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".probe-"):
            pass
    except OSError as exc:
        raise UsageError(f"{what} {folder} is not writable ({exc.strerror or exc})") from None
    return folder


def probe_parent(path: str | os.PathLike, what: str) -> Path:
    """Refuse, before long work, an output ``path`` whose folder is missing or not writable
    (the output itself is written later, next to where this probe was)."""
    import tempfile

    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{what} {path}: its folder {parent} does not exist")
    try:
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".probe-"):
            pass
    except OSError as exc:
        raise UsageError(f"{what} {path}: its folder {parent} is not writable "
                         f"({exc.strerror or exc})") from None  # fmt: skip
    return path


def load_failure(exc: BaseException) -> str:
    """The first line of why numpy (or zipfile) could not read an ``.npz``, for a one-line
    error. Where numpy took the file for a pickle it advises loading it "unsafely using
    allow_pickle": this project never unpickles, so that advice is replaced by what is true."""
    text = str(exc).strip()
    if "pickle" in text.lower():
        return "not an .npz archive; pickled data is never loaded"
    return text.splitlines()[0] if text else type(exc).__name__


def json_value(value: Any) -> Any:
    """``json.dumps(default=...)`` for numpy scalars and arrays, tuples and paths."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray | tuple):
        return np.asarray(value).tolist() if isinstance(value, np.ndarray) else list(value)
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def read_toml(path: str | os.PathLike, what: str) -> dict[str, Any]:
    """A TOML file's table, or a one-line UsageError naming ``what`` (e.g. "config file")
    and the problem: missing, unreadable, not UTF-8 (as TOML must be), or not valid TOML."""
    import tomllib

    path = Path(path)
    try:
        return tomllib.loads(read_input_text(path, what))
    except RecursionError:  # tomllib recurses once per nesting level: 1,000 arrays deep is out
        raise UsageError(f"{path} is not valid TOML a {what} can be: its arrays or tables "
                         "are nested too deep") from None  # fmt: skip
    except UnicodeDecodeError:
        raise UsageError(f"{path} is not a UTF-8 text file (TOML must be UTF-8)") from None
    except OSError as exc:
        raise UsageError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{path} is not valid TOML: {exc}") from None


# --- inputs: one rule for every path a user names ------------------------------------------

GIB = 1 << 30
MIB = 1 << 20
INPUT_LIMITS: dict[str, int] = {
    "recording": 4 * GIB,
    "table": 2 * GIB,
    "calibration file": 1 * MIB,
    "config file": 16 * MIB,
    "model file": 2 * GIB,
    "mesh file": 1 * GIB,
    "record file": 256 * MIB,
    "manifest": 64 * MIB,
    "hand model": 64 * MIB,
}
"""The largest file accepted per kind of input (bytes). Far above any real input (an hour of a
hand's joint states at 100 Hz is ~100 MB of bag; a model a few MB), low enough that a device,
a sparse file or a mistaken path is refused before it is read into memory."""


def input_path(
    path: str | os.PathLike, what: str, limit: int | None = None, folder: bool = False
) -> Path:
    """``path`` checked the one way every input is: it exists, is a regular file (or, where
    ``folder``, a directory, the form some formats take) and holds at most ``limit`` bytes
    (default: :data:`INPUT_LIMITS` for ``what``). Only ``stat`` is called, so a FIFO is never
    opened (opening one blocks until a writer comes) and a device is never read."""
    path = Path(path)
    if folder and path.is_dir():
        return path
    why = not_a_file(path)  # stat only: a FIFO is never opened
    if why is not None:
        raise UsageError(f"{what} {path} {why}")
    try:
        info = path.stat()
    except OSError as exc:
        raise UsageError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    bound = INPUT_LIMITS.get(what, 1 * GIB) if limit is None else limit
    if info.st_size > bound:
        raise UsageError(
            f"{what} {path} is {info.st_size:,} bytes, over the {bound:,}-byte limit for a "
            f"{what}"
        )
    return path


def referenced_file(
    folder: str | os.PathLike, name: str, owner: str, kind: str, what: str = "file"
) -> Path:
    """A file that an input names inside itself (a hand model's ``<include>`` or mesh, a
    glTF's buffer), checked the one way: it lies inside ``folder``, the naming file's own
    (an absolute name, ``..`` or a link that leads out of it is refused, so a model cannot make
    the program read ``/etc/passwd`` or a file beside the user's home), and is an input of
    ``kind`` (:func:`input_path`: a regular file, a FIFO never opened, at most its limit)."""
    folder = Path(folder).resolve()
    target = (folder / name).resolve()
    if not target.is_relative_to(folder):
        raise UsageError(
            f"{owner}: {what} {name!r} lies outside the {kind.removesuffix(' file')}'s folder "
            f"{folder}; every file it includes or references must sit in that folder or below"
        )
    why = not_a_file(target)
    if why is not None:
        raise UsageError(f"{owner}: {what} {name!r} {why}")
    return input_path(target, kind)


def read_input_text(path: str | os.PathLike, what: str, limit: int | None = None) -> str:
    """A checked input file's text (UTF-8), never more than its kind's limit read."""
    path = input_path(path, what, limit)
    bound = INPUT_LIMITS.get(what, 1 * GIB) if limit is None else limit
    try:
        with open(path, "rb") as fh:
            data = fh.read(bound + 1)
    except OSError as exc:
        raise UsageError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if len(data) > bound:  # grew between the check and the read
        raise UsageError(f"{what} {path} is over the {bound:,}-byte limit for a {what}")
    return data.decode("utf-8")


def check_npz_members(
    source: str | os.PathLike | bytes,
    what: str,
    allowed: Callable[[str], bool],
    member_limit: int,
    total_limit: int | None = None,
    limits: dict[str, int] | None = None,
) -> None:
    """Refuse an ``.npz`` (a zip of ``.npy`` arrays) whose members are not all ``allowed`` or
    would decompress past ``member_limit`` bytes each (``total_limit`` together) before any
    is decompressed; the UsageError reads "``what`` <problem>". ``limits`` holds a lower limit
    for some members by name (a model's known grasps: what ``train --known`` can write). Both
    the zip's declared size and each array's own header (its shape times its item size) are
    checked: numpy allocates what the header says, and a zip bomb declares small sizes and
    inflates to gigabytes.
    A source that is no zip archive at all is left to the loader, which says why."""
    import io
    import zipfile

    total_limit = member_limit * 64 if total_limit is None else total_limit
    src = io.BytesIO(source) if isinstance(source, bytes) else source
    if not zipfile.is_zipfile(src):
        return  # not an archive at all: the loader refuses it in its own words
    try:
        with zipfile.ZipFile(src) as zf:
            total = 0
            for info in zf.infolist():
                name = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                if not info.filename.endswith(".npy") or not allowed(name):
                    raise UsageError(f"{what} holds an unexpected member {info.filename!r}")
                total += info.file_size
                bound = min(member_limit, (limits or {}).get(name, member_limit))
                if info.file_size > bound:
                    raise UsageError(
                        f"{what} has a member {info.filename!r} that declares "
                        f"{info.file_size:,} bytes, over the {bound:,}-byte limit"
                    )
                if total > total_limit:
                    raise UsageError(f"{what} declares {total:,} bytes in all, over the "
                                     f"{total_limit:,}-byte limit")  # fmt: skip
                with zf.open(info) as fh:
                    size = _npy_data_bytes(fh)
                if size is None or size > info.file_size:
                    raise UsageError(
                        f"{what} has a member {info.filename!r} whose header does not fit it"
                    )
    except UsageError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UsageError(f"{what} is not a readable .npz file ({why})") from None


def _npy_data_bytes(fh) -> int | None:
    """The bytes an ``.npy`` stream's header says its array holds (None if unreadable)."""
    from numpy.lib import format as npy

    try:
        version = npy.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = npy.read_array_header_1_0(fh, max_header_size=10_000)
        elif version == (2, 0):
            shape, _, dtype = npy.read_array_header_2_0(fh, max_header_size=10_000)
        else:
            return None
    except (ValueError, EOFError, OSError):
        return None
    if any(int(s) < 0 for s in shape):
        return None
    return int(np.prod(shape, dtype=object)) * dtype.itemsize
