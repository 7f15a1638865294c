"""Writing output files so that nothing is lost and nothing is mixed.

Every file linflex writes goes through here:

- :func:`atomic_write` writes a file under a temporary name in the target folder and renames it
  into place (``os.replace``, atomic on POSIX): a reader sees the old file or the new one, never a
  part; a run that fails or is killed leaves the old file as it was.
- :func:`replaced_folder` builds a folder of several files (a report) in a sibling temporary
  folder and swaps it with the target in one step (``renameat2(RENAME_EXCHANGE)`` on Linux; two
  renames elsewhere), so the folder holds the files of one run, never a mix of two.
- :func:`file_lock` serializes (or refuses) concurrent runs on one output with ``fcntl.flock``.

Temporary names start with ``.<target name>.`` and carry the writer's process id, so a later run
removes those left by a killed one (:func:`remove_stale_temporaries`) and never those of a run
that is still alive.

A stop asked for by a signal (:func:`request_stop`, called by the command line's SIGTERM handler)
is honoured at the last moment before an output replaces the old one, even where the handler's
own exception was lost (raised inside a callback whose exceptions Python ignores, such as an
import lock's): the old output stays.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import shutil
import signal
from collections.abc import Iterable, Iterator
from pathlib import Path

from ._errors import LinflexError

try:
    import fcntl
except ImportError:  # pragma: no cover -- not POSIX: no locks, writes stay atomic
    fcntl = None

__all__ = ["OutputError", "Stopped", "atomic_write", "check_output_file", "check_output_folder", "clear_stop_request",
           "file_lock", "raise_if_stop_requested", "remove_stale_temporaries", "replaced_folder", "request_stop"]

# The signal whose stop was asked for (request_stop), if any.
_STOP: list[int] = []


class Stopped(KeyboardInterrupt):
    """SIGTERM (or SIGINT) received: raised in the main thread so that cleanups run."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def request_stop(signum: int) -> None:
    """Record that a signal asked the run to stop: the next output about to be committed is not
    (:func:`raise_if_stop_requested` raises there).

    Parameters
    ----------
    signum : int
        The signal's number.
    """
    _STOP[:] = [int(signum)]


def clear_stop_request() -> None:
    """Forget a stop asked for by :func:`request_stop` (a new run starts)."""
    _STOP.clear()


def raise_if_stop_requested() -> None:
    """Raise :class:`Stopped` where a stop was asked for.

    Raises
    ------
    Stopped
        If :func:`request_stop` was called (the request stays: every later commit refuses too).
    """
    if _STOP:
        raise Stopped(_STOP[0])


class OutputError(LinflexError, OSError):
    """An output path cannot be used: it is a folder where a file is meant (or the reverse), it
    holds files linflex did not write, or another run is writing it."""


def _temporary_name(target: Path, kind: str) -> Path:
    return target.with_name(f".{target.name}.{kind}-{os.getpid()}-{secrets.token_hex(4)}")


def check_output_file(path: str | os.PathLike) -> Path:
    """Refuse an output file path that cannot be written, before any work is done.

    Parameters
    ----------
    path : str or path-like
        The file to be written.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputError
        If ``path`` is an existing folder, ends with a path separator, or its folder exists as a
        file or is not writable.
    """
    text = os.fspath(path)
    path = Path(path)
    if text.endswith((os.sep, "/")) or path.is_dir():
        raise OutputError(f"{text} is a folder; the output is a file (e.g. {path / 'name'})")
    _check_parent(path)
    return path


def check_output_folder(path: str | os.PathLike, owned: Iterable[str]) -> Path:
    """Refuse an output folder that cannot be replaced as a whole, before any work is done.

    Parameters
    ----------
    path : str or path-like
        The folder to be (re)written.
    owned : iterable of str
        The names of the files the writer puts in it: an existing folder may hold only these,
        so that replacing it loses nothing else.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputError
        If ``path`` is an existing file, holds other files, or its parent is not writable.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"{path} is a file; the output is a folder (choose a new or empty folder)")
    here = Path.cwd().resolve()
    if path.resolve() == here or path.resolve() in here.parents:
        raise OutputError(f"{path} is the current folder or holds it; the output folder is replaced as a whole, "
                          "so choose a new or empty folder below it")
    if path.is_dir():
        foreign = sorted(p.name for p in path.iterdir() if p.name not in set(owned))
        if foreign:
            shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
            raise OutputError(f"{path} holds files that linflex did not write ({shown}); the whole folder is "
                              "replaced, so choose a new or empty folder")
    _check_parent(path)
    return path


@contextlib.contextmanager
def _refused(path: Path) -> Iterator[None]:
    """Where the system refuses to create the output (a read-only or special file system, a full
    disk, a permission the checks before could not see): an :class:`OutputError` naming ``path``
    and the system's reason, not an internal error."""
    try:
        yield
    except OutputError:
        raise
    except OSError as err:
        raise OutputError(f"cannot write {path}: {err.strerror or err}") from err


def _check_parent(path: Path) -> None:
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise OutputError(f"cannot write {path}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write {path}: no permission to write in {parent}")


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w", *, encoding: str | None = "utf-8",
                 newline: str | None = None) -> Iterator:
    """Open a temporary file beside ``path``; on success it replaces ``path`` in one step.

    Parameters
    ----------
    path : str or path-like
        The file to write (its folder is created if missing).
    mode : {"w", "wb"}
        Text or binary.
    encoding : str or None
        Text encoding (ignored in binary mode).
    newline : str or None
        As for :func:`open` (``""`` for the csv module).

    Yields
    ------
    file object
        Write to it; it is flushed to disk and renamed to ``path`` when the block ends without
        an exception, and removed otherwise (the old ``path`` stays as it was).

    Raises
    ------
    OutputError
        If ``path`` is a folder.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "table.csv"
    >>> with atomic_write(target) as f:
    ...     _ = f.write("a,b\\n")
    >>> target.read_text()
    'a,b\\n'
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write: mode must be 'w' or 'wb', got {mode!r}")
    path = check_output_file(path)
    temporary = _temporary_name(path, "tmp")
    with _refused(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies, as for open()
    try:
        kwargs = {} if mode == "wb" else {"encoding": encoding, "newline": newline}
        with open(fd, mode, **kwargs) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        with contextlib.suppress(FileNotFoundError):
            os.chmod(temporary, os.stat(path).st_mode & 0o7777)  # keep the mode of the file it replaces
        raise_if_stop_requested()
        os.replace(temporary, path)
        _sync_folder(path.parent)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


def _sync_folder(folder: Path) -> None:
    """Make a rename durable (POSIX: fsync the folder); harmless where folders cannot be opened."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover -- e.g. Windows
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover -- some file systems refuse fsync on folders
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def file_lock(path: str | os.PathLike, *, wait: bool = True, what: str = "this output") -> Iterator[None]:
    """Hold an exclusive ``fcntl.flock`` on ``path`` (created if missing; never removed, as removing a
    lock file lets two runs each lock a different file).

    Parameters
    ----------
    path : str or path-like
        The lock file.
    wait : bool
        Wait for another holder to release it (serialize), or refuse at once.
    what : str
        What the lock protects, for the message.

    Yields
    ------
    None

    Raises
    ------
    OutputError
        With ``wait=False``, if another process holds the lock (its process id is named).
    """
    if fcntl is None:  # pragma: no cover
        yield
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            raise OutputError(f"{what} is being written by another linflex run (process {holder}, lock {path}); "
                              "wait for it to finish or choose another output") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


def remove_stale_temporaries(target: str | os.PathLike) -> list[Path]:
    """Remove the temporary files and folders of ``target`` left by writers that no longer run.

    Parameters
    ----------
    target : str or path-like
        The output whose ``.<name>.tmp-<pid>-*`` / ``.<name>.old-<pid>-*`` siblings are checked.

    Returns
    -------
    list of pathlib.Path
        What was removed.
    """
    target = Path(target)
    removed = []
    if not target.parent.is_dir():
        return removed
    prefix = f".{target.name}."
    for candidate in target.parent.iterdir():
        if not candidate.name.startswith(prefix):
            continue
        kind_pid = candidate.name[len(prefix):].split("-")
        if len(kind_pid) != 3 or kind_pid[0] not in ("tmp", "old") or not kind_pid[1].isdigit():
            continue
        if _alive(int(kind_pid[1])):
            continue
        if candidate.is_dir() and not candidate.is_symlink():
            shutil.rmtree(candidate, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                candidate.unlink()
        removed.append(candidate)
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextlib.contextmanager
def replaced_folder(target: str | os.PathLike, owned: Iterable[str]) -> Iterator[Path]:
    """Build a folder's new content in a sibling temporary folder, then swap it with ``target``.

    Parameters
    ----------
    target : str or path-like
        The folder to replace (created if missing).
    owned : iterable of str
        The file names the writer puts in it (see :func:`check_output_folder`, called first).

    Yields
    ------
    pathlib.Path
        The temporary folder: write the files there. When the block ends without an exception,
        it replaces ``target`` as a whole (under a lock beside ``target``, so concurrent writers
        take turns and the last one wins whole); otherwise it is removed and ``target`` keeps its
        previous content.

    Raises
    ------
    OutputError
        As :func:`check_output_folder`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "report"
    >>> with replaced_folder(target, ["a.txt"]) as build:
    ...     _ = (build / "a.txt").write_text("one run")
    >>> sorted(p.name for p in target.iterdir())
    ['a.txt']
    """
    owned = tuple(owned)
    target = check_output_folder(target, owned).absolute()
    build = _temporary_name(target, "tmp")
    with _refused(target):
        target.parent.mkdir(parents=True, exist_ok=True)
        os.mkdir(build, 0o777)  # the umask applies
    try:
        yield build
        with file_lock(target.parent / f".{target.name}.lock", what=str(target)):
            check_output_folder(target, owned)  # another run may have put files there meanwhile
            remove_stale_temporaries(target)
            with contextlib.suppress(FileNotFoundError):
                os.chmod(build, os.stat(target).st_mode & 0o7777)
            raise_if_stop_requested()
            _swap_folders(build, target)
            _sync_folder(target.parent)
    finally:
        if build.exists():
            shutil.rmtree(build, ignore_errors=True)


def _swap_folders(new: Path, target: Path) -> None:
    """Put ``new`` at ``target``; afterwards ``new`` holds the old content (or does not exist)."""
    if not target.exists():
        os.rename(new, target)
        return
    if _exchange(new, target):
        return
    old = _temporary_name(target, "old")  # pragma: no cover -- systems without renameat2
    os.rename(target, old)  # pragma: no cover
    os.rename(new, target)  # pragma: no cover
    os.rename(old, new)  # pragma: no cover


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically with Linux's ``renameat2(RENAME_EXCHANGE)``; False where unsupported."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):  # pragma: no cover -- not glibc >= 2.28
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()  # pragma: no cover
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):  # pragma: no cover -- the file system refuses
        return False
    raise OSError(code, os.strerror(code), os.fspath(b))  # pragma: no cover
