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
from collections.abc import Iterable, Iterator
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


def existing_outputs(
    folder: str | os.PathLike, names: Iterable[str], what: str, force: bool
) -> None:
    """Refuse (unless ``force``) a folder that already holds any of the files a command would
    write there: an earlier report or figure is kept unless the user asks otherwise."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    for name in names:
        refuse_special(folder / name, what)
    if force:
        return
    found = sorted(n for n in names if (folder / n).exists())
    if found:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise UsageError(
            f"{what} {folder} already holds {found[0]}{more} from an earlier run; "
            "add --force to overwrite, or choose another folder"
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
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UsageError(f"{what} {path} does not exist") from None
    except UnicodeDecodeError:
        raise UsageError(f"{path} is not a UTF-8 text file (TOML must be UTF-8)") from None
    except OSError as exc:
        raise UsageError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{path} is not valid TOML: {exc}") from None
