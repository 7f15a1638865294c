"""The command line's boundary: exit codes, what counts as bad input, signals.

Exit codes (``linflex --help`` and the README say the same):

====  ==========================================================================================
0     success (and, for ``report``, the closed loop is stable and every requirement is met)
1     the analysis ran and found a problem: an unstable closed loop or a failed requirement
      (``report``) or failed cases
      (``sweep``)
2     bad input: a scene, spec, option or file that cannot be used; one message, no traceback
      (``--debug`` shows it)
3     internal error: a bug in linflex; the traceback is printed with a request to report it
130   interrupted by SIGINT (Ctrl-C); 143: stopped by SIGTERM. What was finished is kept.
====  ==========================================================================================
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import traceback
from collections.abc import Iterator
from pathlib import Path

from ..system._files import Stopped, clear_stop_request, request_stop

__all__ = ["EXIT_CODES", "InputError", "Stopped", "check_input_file", "exit_status", "reading",
           "stopping_on_signals"]

OK, PROBLEM, BAD_INPUT, INTERNAL = 0, 1, 2, 3

#: The help text of the exit codes (``linflex --help``).
EXIT_CODES = """exit codes:
  0    success (report: the closed loop is stable and every requirement is met)
  1    the analysis ran and found a problem: an unstable closed loop or a failed requirement (report),
       failed cases (sweep)
  2    bad input: scene, spec, options or files; one message, no traceback (--debug shows it)
  3    internal error in linflex: the traceback is printed; please report it
  130  interrupted (SIGINT, Ctrl-C); 143: stopped (SIGTERM); finished work is kept
"""


class InputError(Exception):
    """Bad input found at the command line's boundary: the message names the file once."""

    def __init__(self, message: str, path: str | os.PathLike | None = None):
        text = " ".join(str(message).split()) if "\n" not in str(message) else str(message).strip()
        if path is not None and os.fspath(path) not in text and Path(path).name not in text:
            text = f"{os.fspath(path)}: {text}"
        super().__init__(text)


def _bad_input_types() -> tuple[type[BaseException], ...]:
    import sys as _sys

    from ..system._errors import LinflexError

    tomllib = _sys.modules.get("tomllib") or _sys.modules.get("tomli")
    toml_error = (tomllib.TOMLDecodeError,) if tomllib is not None else ()
    return (LinflexError, InputError, UnicodeDecodeError, *toml_error)


def check_input_file(path: str | os.PathLike, what: str = "file") -> Path:
    """Refuse an input file that cannot be read as UTF-8 text, naming it once.

    Parameters
    ----------
    path : str or path-like
        The file (a scene or a sweep spec).
    what : str
        What it is, for the message.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    InputError
        If it does not exist, is a folder, cannot be read, is not UTF-8 or starts with a byte
        order mark.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"no such {what}", path)
    if path.is_dir():
        raise InputError(f"is a folder, not a {what}", path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise InputError(f"cannot read the {what}: {err.strerror or err}", path) from err
    if data.startswith(b"\xef\xbb\xbf"):
        raise InputError(f"the {what} starts with a UTF-8 byte order mark, which TOML does not allow; "
                         "save it as UTF-8 without BOM", path)
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[:err.start].count(b"\n") + 1
        raise InputError(f"the {what} is not UTF-8 text (byte 0x{data[err.start]:02x} on line {line}); "
                         "save it as UTF-8", path) from err
    return path


#: Raw exceptions that, raised while a user's file is being read and checked, come from its
#: content (a value of the wrong kind the loader does not check yet).
_CONTENT_ERRORS = (TypeError, ValueError, ArithmeticError, LookupError)


@contextlib.contextmanager
def reading(path: str | os.PathLike, *, loading: bool = False) -> Iterator[None]:
    """Errors of bad input raised in the block become :class:`InputError` naming ``path`` once.

    Parameters
    ----------
    path : str or path-like
        The file the block reads or analyses.
    loading : bool
        The block only loads and validates ``path``: raw ``TypeError``, ``ValueError``,
        ``ArithmeticError`` and ``LookupError`` then come from its content and are bad input
        too (outside loading they are internal errors, exit code 3).

    Yields
    ------
    None
    """
    try:
        yield
    except InputError:
        raise
    except _bad_input_types() as err:
        raise InputError(str(err), path) from err
    except OSError as err:
        if err.filename is not None and _same_file(err.filename, path):
            raise InputError(err.strerror or str(err), path) from err
        if err.filename is not None and _beside(err.filename, path):  # a file the input names (modal data)
            raise InputError(f"{os.fsdecode(err.filename)}: {err.strerror or err}", path) from err
        raise
    except _CONTENT_ERRORS as err:
        if not loading:
            raise
        raise InputError(f"cannot be loaded: {type(err).__name__}: {err} (a value of the wrong kind or size that "
                         "linflex does not check yet; please report it so that the message can name the entry)",
                         path) from err


def _beside(name, path) -> bool:
    """``name`` is in the folder of the input ``path`` or below it."""
    try:
        return Path(path).resolve().parent in Path(os.fsdecode(name)).resolve().parents
    except OSError:  # pragma: no cover
        return False


def _same_file(a, b) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except OSError:  # pragma: no cover
        return False


def exit_status(command: str, err: BaseException, *, debug: bool, user_paths=()) -> int:
    """Print the message of an exception that ended a command and return its exit status.

    Parameters
    ----------
    command : str
        The subcommand, for the message prefix.
    err : BaseException
        The exception.
    debug : bool
        Print the traceback of bad input too.
    user_paths : iterable of path-like
        The files and folders named on the command line: an ``OSError`` on one of them (or
        inside an output folder) is bad input.

    Returns
    -------
    int
        2 for bad input, 3 for an internal error.
    """
    prefix = f"linflex {command}" if command else "linflex"
    if isinstance(err, _bad_input_types()) or (isinstance(err, OSError) and _on_user_path(err, user_paths)):
        if debug:
            traceback.print_exception(err)
        message = str(err)
        if isinstance(err, OSError) and not isinstance(err, _bad_input_types()) and err.filename is not None:
            message = f"{err.filename}: {err.strerror or err}"
        print(f"{prefix}: error: {message}", file=sys.stderr)
        return BAD_INPUT
    traceback.print_exception(err)
    print(f"{prefix}: internal error ({type(err).__name__}): linflex failed where it should have given a result or named the bad input. "
          "Please report it to the linflex maintainers with the command line, the input files and the "
          "traceback above.", file=sys.stderr)
    return INTERNAL


def _on_user_path(err: OSError, user_paths) -> bool:
    names = [n for n in (err.filename, getattr(err, "filename2", None)) if n is not None]
    if not names:
        return False
    for name in names:
        target = Path(os.fsdecode(name)).absolute()
        for user in user_paths:
            user = Path(user).absolute()
            if target == user or user in target.parents or target in user.parents:
                return True
    return False


@contextlib.contextmanager
def stopping_on_signals() -> Iterator[None]:
    """SIGTERM raises :class:`Stopped` in the main thread (as Ctrl-C raises KeyboardInterrupt),
    so that temporary files are removed, worker processes stopped and finished rows kept.

    Yields
    ------
    None
    """
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):
        signal.signal(signum, signal.SIG_DFL)  # a second SIGTERM ends the process at once
        # recorded as well: raised inside a callback whose exceptions Python ignores (an import
        # lock's), Stopped is lost, and the request still keeps the run from committing an output
        request_stop(signum)
        raise Stopped(signum)

    def unraisable(info, hook=sys.unraisablehook):
        # a Stopped lost that way is recorded (request_stop): no "Exception ignored" traceback
        if not isinstance(info.exc_value, Stopped):
            hook(info)

    clear_stop_request()
    previous, previous_hook = signal.signal(signal.SIGTERM, stop), sys.unraisablehook
    sys.unraisablehook = unraisable
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = previous_hook
        clear_stop_request()
