"""Printing the report's HTML page to PDF with headless Chromium.

Two ways, same result: ``print_pdf`` runs ``chromium --headless --print-to-pdf`` on a file
(about a second of start-up before the page loads); a :class:`PdfPrinter` starts Chromium
before the analysis and prints over the DevTools protocol on a pipe
(``--remote-debugging-pipe``: JSON messages ending in a NUL byte, commands on the browser's fd 3,
replies on its fd 4), so that the start-up overlaps the analysis. A printer that fails falls
back to ``print_pdf``.
"""

from __future__ import annotations

import base64
import contextlib
import fcntl
import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from linflex.system import OutputError

__all__ = ["PdfPrinter", "chromium", "print_pdf"]  # PdfPrinter is public (linflex.stability.report)

_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
          "--disable-component-update", "--disable-sync", "--disable-extensions")


def chromium() -> str | None:
    """The headless browser that prints the PDF (``chromium`` or ``chromium-browser``), or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def print_pdf(browser: str, page: Path, out: Path, profile: Path) -> None:
    """Print ``page`` to ``out`` with ``chromium --print-to-pdf`` (a fresh profile, no header)."""
    flags = [*_FLAGS, f"--user-data-dir={profile}", "--no-pdf-header-footer", f"--print-to-pdf={out}", page.as_uri()]
    try:
        done = subprocess.run([browser, *flags], capture_output=True, text=True, timeout=180)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise OutputError(f"{browser} could not print the report to PDF: {err}") from err
    if not out.exists() or not out.read_bytes().startswith(b"%PDF"):
        raise OutputError(f"{browser} did not print the report to PDF (exit {done.returncode}): "
                          + " ".join(done.stderr.split()[-40:]))


class PdfPrinter:
    """A headless Chromium started early, printing pages over the DevTools pipe.

    Use as a context manager (the browser ends with it, also on errors and signals); a printer
    whose browser could not start or answer prints with ``print_pdf`` instead.

    Parameters
    ----------
    browser : str, optional
        The browser executable; default ``chromium`` (or ``chromium-browser``) on the PATH.
        Without one nothing starts, and :meth:`print` raises (the report then writes its
        plain fallback PDF).

    Examples
    --------
    Start the browser, analyse, then print (the start-up overlaps the analysis):

    >>> from linflex.stability.report import PdfPrinter, analyse_scene, stability_report
    >>> with PdfPrinter() as printer:                                        # doctest: +SKIP
    ...     report = stability_report(analyse_scene("examples/attitude_control.toml"))
    ...     path = report.to_pdf("report.pdf", printer=printer)
    """

    def __init__(self, browser: str | None = None) -> None:
        self.browser = browser or chromium()
        self._folder = tempfile.TemporaryDirectory(prefix=".linflex-browser-")
        self._process: subprocess.Popen | None = None
        self._buffer = b""
        self._id = 0
        if self.browser is None:
            return
        commands_r, commands_w = os.pipe()
        replies_r, replies_w = os.pipe()
        # the child's fds 3 and 4, from copies above them (dup2 must not overwrite the other end)
        theirs = (fcntl.fcntl(commands_r, fcntl.F_DUPFD, 10), fcntl.fcntl(replies_w, fcntl.F_DUPFD, 10))

        def child() -> None:  # pragma: no cover (runs in the child)
            os.dup2(theirs[0], 3)
            os.dup2(theirs[1], 4)

        try:
            self._process = subprocess.Popen(
                [self.browser, *_FLAGS, f"--user-data-dir={Path(self._folder.name) / 'profile'}",
                 "--remote-debugging-pipe"], pass_fds=(3, 4, *theirs), preexec_fn=child,
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        except OSError:
            self._process = None
        for fd in (commands_r, replies_w, *theirs):
            os.close(fd)
        self._commands = os.fdopen(commands_w, "wb", buffering=0)
        self._replies = os.fdopen(replies_r, "rb", buffering=0)

    def _send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        self._id += 1
        message = {"id": self._id, "method": method, "params": params or {}}
        if session is not None:
            message["sessionId"] = session
        self._commands.write(json.dumps(message).encode() + b"\0")
        reply = self._wait(lambda m: m.get("id") == self._id)
        if "error" in reply:
            raise RuntimeError(f"{method}: {reply['error']}")
        return reply.get("result", {})

    def _wait(self, wanted) -> dict:
        while True:
            while b"\0" not in self._buffer:
                chunk = self._replies.read(1 << 16)
                if not chunk:
                    raise RuntimeError("the browser closed its pipe")
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            message = json.loads(raw)
            if wanted(message):
                return message

    def _print_over_pipe(self, page: Path) -> bytes:
        target = self._send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self._send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self._send("Page.enable", session=session)
        self._send("Page.navigate", {"url": page.as_uri()}, session=session)
        self._wait(lambda m: m.get("method") == "Page.loadEventFired" and m.get("sessionId") == session)
        data = self._send("Page.printToPDF", {"printBackground": True, "preferCSSPageSize": True,
                                              "displayHeaderFooter": False}, session=session)["data"]
        self._send("Target.closeTarget", {"targetId": target})
        return base64.b64decode(data)

    def print(self, page: Path, out: Path) -> None:
        """Print the HTML file ``page`` to the PDF file ``out``.

        Parameters
        ----------
        page, out : pathlib.Path
            The page (read by the browser) and the PDF written.

        Raises
        ------
        linflex.system.OutputError
            When no browser is installed or neither way prints the page.
        """
        if self.browser is None:
            raise OutputError("no chromium to print the PDF")
        if self._process is not None and self._process.poll() is None:
            try:
                data = self._print_over_pipe(page)
            except (OSError, RuntimeError, ValueError, KeyError):
                data = b""
            if data.startswith(b"%PDF"):
                out.write_bytes(data)
                return
        print_pdf(self.browser, page, out, Path(self._folder.name) / "profile-cli")

    def close(self) -> None:
        """End the browser (asked to close, killed after 5 s) and remove its profile."""
        if self._process is not None:
            with contextlib.suppress(OSError, RuntimeError, ValueError):
                if self._process.poll() is None:
                    self._id += 1
                    self._commands.write(json.dumps({"id": self._id, "method": "Browser.close"}).encode() + b"\0")
            with contextlib.suppress(OSError):
                self._commands.close()
            try:
                self._process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
            with contextlib.suppress(OSError):
                self._replies.close()
            self._process = None
        self._folder.cleanup()

    def __enter__(self) -> PdfPrinter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
