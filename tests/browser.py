"""A real headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe:
no port, no extra package), for the report tests: load a page, collect what its console would
show (console.error/warn, uncaught exceptions, failed loads), evaluate JavaScript, take a
screenshot. `find_chromium()` is None where no Chromium is installed (the tests then skip)."""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time


NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


def find_chromium() -> str | None:
    """$CHROMIUM, else the first Chromium on PATH; None when there is none."""
    given = os.environ.get("CHROMIUM")
    if given and shutil.which(given):
        return shutil.which(given)
    return next((shutil.which(n) for n in NAMES if shutil.which(n)), None)


def _high(fd: int) -> int:
    """`fd` moved to a descriptor number above 9 (inheritable); the old one closed."""
    import fcntl

    new = fcntl.fcntl(fd, fcntl.F_DUPFD, 10)
    os.close(fd)
    os.set_inheritable(new, True)
    return new


class Browser:
    """One headless Chromium with one page; `with Browser() as b: b.load(url)`."""

    def __init__(self, exe: str | None = None, *, width: int = 1200, height: int = 900):
        exe = exe or find_chromium()
        if exe is None:
            raise RuntimeError("no Chromium found")
        self.profile = tempfile.mkdtemp(prefix="rhythmjax-chromium-")
        to_child, self._w = os.pipe()
        self._r, from_child = os.pipe()
        # above 9, so that moving them to 3 and 4 in the child cannot clobber one another
        to_child, from_child = (_high(fd) for fd in (to_child, from_child))
        args = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                "--disable-extensions", f"--user-data-dir={self.profile}",
                f"--window-size={width},{height}", "--remote-debugging-pipe", "about:blank"]

        # Chromium reads commands on fd 3 and writes answers on fd 4: a small launcher moves
        # the pipes there (no preexec_fn: forking a process that runs JAX warns)
        launch = ("import os, sys; a, b = int(sys.argv[1]), int(sys.argv[2]); os.dup2(a, 3); "
                  "os.dup2(b, 4); os.close(a); os.close(b); os.execv(sys.argv[3], sys.argv[3:])")
        self.log = os.path.join(self.profile, "chromium.log")
        with open(self.log, "wb") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", launch, str(to_child), str(from_child), *args],
                pass_fds=(to_child, from_child), stdin=subprocess.DEVNULL, stdout=log,
                stderr=log)
        os.close(to_child)
        os.close(from_child)
        self._buf = b""
        self._id = 0
        self.events: list[dict] = []
        try:
            target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
            self.session = self.call("Target.attachToTarget",
                                     {"targetId": target, "flatten": True})["sessionId"]
            for domain in ("Page", "Runtime", "Log", "Network"):
                self.call(f"{domain}.enable", session=True)
        except BaseException:
            self.close()
            raise

    # -- protocol -------------------------------------------------------------------------------
    def _read(self, timeout: float) -> dict:
        end = time.monotonic() + timeout
        while b"\0" not in self._buf:
            if time.monotonic() > end or self.proc.poll() is not None:
                raise TimeoutError(f"Chromium did not answer: {self._log_tail()}")
            import select

            ready, _, _ = select.select([self._r], [], [], 0.5)
            if ready:
                chunk = os.read(self._r, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"Chromium closed the pipe: {self._log_tail()}")
                self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def _log_tail(self) -> str:
        try:
            with open(self.log, errors="replace") as f:
                return f.read()[-2000:]
        except OSError:
            return "(no log)"

    def call(self, method: str, params: dict | None = None, *, session: bool = False,
             timeout: float = 30.0) -> dict:
        """Send one command and wait for its answer (events met meanwhile are kept)."""
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = self.session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        while True:
            got = self._read(timeout)
            if got.get("id") == self._id:
                if "error" in got:
                    raise RuntimeError(f"{method}: {got['error']}")
                return got.get("result", {})
            self.events.append(got)

    def wait_event(self, method: str, timeout: float = 30.0) -> dict:
        """The first event `method` (already met, or coming)."""
        for e in self.events:
            if e.get("method") == method:
                return e
        while True:
            got = self._read(timeout)
            self.events.append(got)
            if got.get("method") == method:
                return got

    # -- page -----------------------------------------------------------------------------------
    def load(self, url: str, timeout: float = 30.0) -> None:
        """Navigate and wait for the load event (and a short settle for late errors)."""
        self.events = []  # the errors of this page only
        self.call("Page.navigate", {"url": url}, session=True)
        self.wait_event("Page.loadEventFired", timeout)
        self.call("Runtime.evaluate", {"expression": "new Promise(r => setTimeout(r, 300))",
                                       "awaitPromise": True}, session=True)

    def evaluate(self, expression: str):
        """The value of a JavaScript expression on the page."""
        got = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True},
                        session=True)
        if "exceptionDetails" in got:
            raise RuntimeError(f"{expression}: {got['exceptionDetails']}")
        return got["result"].get("value")

    def console_errors(self) -> list[str]:
        """What the console would show as errors or warnings: console.error/warn calls,
        uncaught exceptions, log entries of level error or warning (failed loads included)
        and failed network requests."""
        out = []
        for e in self.events:
            m, p = e.get("method"), e.get("params", {})
            if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "warning",
                                                                    "assert"):
                out.append(f"console.{p['type']}: {p.get('args')}")
            elif m == "Runtime.exceptionThrown":
                out.append(f"exception: {p.get('exceptionDetails', {}).get('text')}")
            elif m == "Log.entryAdded" and p["entry"]["level"] in ("error", "warning"):
                out.append(f"log {p['entry']['level']}: {p['entry'].get('text')} "
                           f"{p['entry'].get('url', '')}")
            elif m == "Network.loadingFailed" and not p.get("canceled"):
                out.append(f"load failed: {p.get('errorText')}")
        return out

    def screenshot(self, path, full_page: bool = True) -> None:
        """A PNG of the page (the whole page's height when `full_page`)."""
        params = {"format": "png"}
        if full_page:
            params["captureBeyondViewport"] = True
            h = self.evaluate("document.documentElement.scrollHeight")
            w = self.evaluate("document.documentElement.scrollWidth")
            params["clip"] = {"x": 0, "y": 0, "width": w, "height": h, "scale": 1}
        data = self.call("Page.captureScreenshot", params, session=True)["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def close(self) -> None:
        """Quit Chromium and remove its profile."""
        try:
            self.call("Browser.close", timeout=5)
        except (RuntimeError, TimeoutError, OSError):
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for fd in (self._r, self._w):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
