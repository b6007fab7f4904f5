"""Load a local HTML page in headless Chromium and report what a reader would see go wrong.

A minimal Chrome DevTools Protocol client over ``--remote-debugging-pipe`` (Chromium
reads commands from file descriptor 3 and writes answers and events to 4, each message a
JSON text ended by a NUL byte): no browser-driver dependency. :func:`inspect_page` opens
the page, waits for its load event and returns every image with whether it loaded, and
every console error, uncaught exception and failed resource load.
"""

from __future__ import annotations

import fcntl
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-dev-shm-usage", "--remote-debugging-pipe",
)


def find_chromium() -> str | None:
    """Path of a Chromium executable on PATH, or None."""
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


class _Pipe:
    """Messages to and from one browser over the debugging pipe."""

    def __init__(self, write_fd: int, read_fd: int) -> None:
        self.write_fd, self.read_fd = write_fd, read_fd
        self.buffer = b""
        self.next_id = 0
        self.events: list[dict] = []

    def send(self, method: str, params: dict | None = None, session: str | None = None,
             timeout: float = 30.0) -> dict:
        """Send a command and return its result (events that arrive meanwhile are kept)."""
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self.write_fd, json.dumps(message).encode() + b"\0")
        while True:
            reply = self._receive(timeout)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_for(self, method: str, timeout: float = 60.0) -> dict:
        """The first event ``method`` (kept or still to come)."""
        for event in self.events:
            if event.get("method") == method:
                return event
        deadline = time.monotonic() + timeout
        while True:
            event = self._receive(max(deadline - time.monotonic(), 0.0))
            self.events.append(event)
            if event.get("method") == method:
                return event

    def _receive(self, timeout: float) -> dict:
        deadline = time.monotonic() + timeout
        while b"\0" not in self.buffer:
            ready, _, _ = select.select([self.read_fd], [], [], max(deadline - time.monotonic(), 0.0))
            if not ready:
                raise TimeoutError("no answer from the browser")
            chunk = os.read(self.read_fd, 1 << 16)
            if not chunk:
                raise RuntimeError("the browser closed the debugging pipe")
            self.buffer += chunk
        message, self.buffer = self.buffer.split(b"\0", 1)
        return json.loads(message)


IMAGES = "JSON.stringify(Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, i.naturalWidth]))"


def inspect_page(html: Path, chromium: str, timeout: float = 60.0) -> dict:
    """Open ``html`` in headless Chromium.

    Returns
    -------
    dict
        ``images``: list of (src, complete, natural width [px]); ``errors``: console
        errors, uncaught exceptions and failed loads, as text.
    """
    read_cmd, write_cmd = os.pipe()  # the browser reads commands on fd 3
    read_out, write_out = os.pipe()  # and writes answers on fd 4
    with tempfile.TemporaryDirectory(prefix="polywear-chromium-") as profile:

        def fds_3_and_4() -> None:  # in the child, before the other descriptors are closed
            high_cmd, high_out = (fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (read_cmd, write_out))
            os.dup2(high_cmd, 3)
            os.dup2(high_out, 4)

        proc = subprocess.Popen([chromium, *FLAGS, f"--user-data-dir={profile}", "about:blank"],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                pass_fds=(3, 4), preexec_fn=fds_3_and_4)
        os.close(read_cmd)
        os.close(write_out)
        pipe = _Pipe(write_cmd, read_out)
        try:
            target = pipe.send("Target.createTarget", {"url": "about:blank"}, timeout=timeout)["targetId"]
            session = pipe.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
            for domain in ("Page", "Runtime", "Log", "Network"):
                pipe.send(f"{domain}.enable", session=session)
            pipe.send("Page.navigate", {"url": html.resolve().as_uri()}, session=session)
            pipe.wait_for("Page.loadEventFired", timeout)
            value = pipe.send("Runtime.evaluate", {"expression": IMAGES, "returnByValue": True},
                              session=session)["result"]["value"]
            try:
                pipe.send("Browser.close", timeout=5.0)
            except (RuntimeError, TimeoutError):
                pass
        finally:
            os.close(write_cmd)
            os.close(read_out)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    return {"images": [tuple(i) for i in json.loads(value)], "errors": _errors(pipe.events)}


def _errors(events: list[dict]) -> list[str]:
    """Console errors, uncaught exceptions and failed resource loads among the events."""
    out = []
    for event in events:
        method, params = event.get("method"), event.get("params", {})
        if method == "Runtime.exceptionThrown":
            out.append(f"exception: {params['exceptionDetails'].get('text')}")
        elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
            out.append("console: " + " ".join(str(a.get("value", a.get("description"))) for a in params["args"]))
        elif method == "Log.entryAdded" and params["entry"].get("level") == "error":
            out.append(f"log: {params['entry'].get('text')} {params['entry'].get('url', '')}")
        elif method == "Network.loadingFailed":
            out.append(f"failed load: {params.get('errorText')}")
    return out
