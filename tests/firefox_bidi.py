"""Test helper: Debian's firefox-esr driven over the W3C WebDriver BiDi protocol, with nothing in between.

Playwright's own Firefox build is never downloaded, and its BiDi path asks Debian's firefox-esr for commands it
does not have (``emulation.setMediaFeaturesOverride``); the dashboard only needs the standard commands: open a
page, evaluate script, take screenshots, hear console errors. So this speaks them itself over one WebSocket:

    with FirefoxBidi.launch() as ff:
        ff.navigate(url)
        ff.wait_for_js("window.pitchside?.layout", 30)
        ff.screenshot(path)
        assert not ff.console_errors

Headless by default; WebGL needs a real window, on a virtual X display (Xvfb):

    with virtual_display() as display, FirefoxBidi.launch(display=display) as ff:
        ...
"""

from __future__ import annotations

import base64
import contextlib
import json
import math
import os
import re
import select
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

FIREFOX = Path("/usr/bin/firefox-esr")
XVFB = Path("/usr/bin/Xvfb")
LISTENING = re.compile(r"WebDriver BiDi listening on (ws://[^\s]+)")

# user.js: no first-run pages, telemetry, updates, safe-browsing downloads or other background network noise
PREFS: dict[str, bool | int | str] = {
    "app.normandy.enabled": False,
    "app.update.auto": False,
    "app.update.enabled": False,
    "browser.aboutwelcome.enabled": False,
    "browser.newtabpage.enabled": False,
    "browser.ping-centre.telemetry": False,
    "browser.safebrowsing.blockedURIs.enabled": False,
    "browser.safebrowsing.downloads.enabled": False,
    "browser.safebrowsing.malware.enabled": False,
    "browser.safebrowsing.phishing.enabled": False,
    "browser.search.update": False,
    "browser.sessionstore.resume_from_crash": False,
    "browser.shell.checkDefaultBrowser": False,
    "browser.startup.homepage_override.mstone": "ignore",
    "browser.startup.page": 0,
    "browser.tabs.warnOnClose": False,
    "datareporting.healthreport.uploadEnabled": False,
    "datareporting.policy.dataSubmissionEnabled": False,
    "extensions.update.enabled": False,
    "network.captive-portal-service.enabled": False,
    "network.connectivity-service.enabled": False,
    "services.settings.server": "http://127.0.0.1:9/",
    "toolkit.telemetry.enabled": False,
    "toolkit.telemetry.reportingpolicy.firstRun": False,
    "toolkit.telemetry.server": "http://127.0.0.1:9/",
    # offline: whatever a page (or an embedded viewer) asks of other hosts fails at once, on a closed local port
    "network.proxy.type": 1,
    "network.proxy.http": "127.0.0.1",
    "network.proxy.http_port": 9,
    "network.proxy.ssl": "127.0.0.1",
    "network.proxy.ssl_port": 9,
    "network.proxy.no_proxies_on": "localhost, 127.0.0.1",
    "network.proxy.allow_hijacking_localhost": False,
    # software WebGL (Mesa llvmpipe) is blocklisted by default; with a display (Xvfb) this turns it on
    "webgl.force-enabled": True,
}


class BidiError(RuntimeError):
    """A command the browser answered with an error, or a script that threw."""


@dataclass
class LogEntry:
    """One log.entryAdded event: a console message or an uncaught exception ("javascript")."""

    kind: str
    level: str
    text: str
    source: str = ""


@dataclass
class FirefoxBidi:
    """A running firefox-esr and its BiDi session on the first tab."""

    process: subprocess.Popen[bytes]
    profile: Path
    ws: Any  # websockets.sync.client.ClientConnection
    context: str = ""
    log: list[LogEntry] = field(default_factory=list)
    failed_requests: list[tuple[str, str]] = field(default_factory=list)  # (URL, error) of network.fetchError
    stderr: list[str] = field(default_factory=list)
    _next_id: int = 0

    # -- start and stop ---------------------------------------------------------------------------------
    @classmethod
    @contextlib.contextmanager
    def launch(cls, width: int = 1600, height: int = 1200, timeout: float = 60.0,
               display: str | None = None) -> Iterator[FirefoxBidi]:
        """Starts firefox-esr on a fresh profile, opens a session and sizes the tab's viewport.

        Headless unless ``display`` names an X display (see virtual_display): headless firefox-esr has no WebGL
        at all, a real window on Xvfb gets WebGL 2 from Mesa's software renderer (llvmpipe)."""
        from websockets.sync.client import connect

        if not FIREFOX.exists():
            raise FileNotFoundError(f"{FIREFOX} is missing: apt-get install firefox-esr")
        profile = Path(tempfile.mkdtemp(prefix="pitchside-firefox-"))
        (profile / "user.js").write_text("".join(f"user_pref({json.dumps(k)}, {json.dumps(v)});\n"
                                                 for k, v in PREFS.items()))
        env = dict(os.environ, MOZ_CRASHREPORTER_DISABLE="1")
        if display is None:
            env["MOZ_HEADLESS"] = "1"
        else:
            env.pop("MOZ_HEADLESS", None)
            env.pop("WAYLAND_DISPLAY", None)
            env.update(DISPLAY=display, GDK_BACKEND="x11")
        process = subprocess.Popen([str(FIREFOX), *(["--headless"] if display is None else []), "--no-remote",
                                    "--remote-debugging-port=0", "--profile", str(profile), "about:blank"],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, start_new_session=True)
        stderr: list[str] = []
        found = threading.Event()
        threading.Thread(target=_read_stderr, args=(process, stderr, found), daemon=True).start()
        ff: FirefoxBidi | None = None
        try:
            if not found.wait(timeout):
                raise TimeoutError(f"firefox-esr did not start WebDriver BiDi in {timeout} s:\n" + "".join(stderr))
            match = next(m for line in stderr if (m := LISTENING.search(line)))
            ws = connect(match.group(1).rstrip("/") + "/session", max_size=None, open_timeout=timeout)
            ff = cls(process, profile, ws, stderr=stderr)
            ff.command("session.new", {"capabilities": {"alwaysMatch": {"acceptInsecureCerts": True}}})
            ff.command("session.subscribe", {"events": ["log.entryAdded", "network.fetchError"]})
            ff.context = ff.command("browsingContext.getTree", {"maxDepth": 0})["contexts"][0]["context"]
            ff.command("browsingContext.setViewport", {"context": ff.context,
                                                       "viewport": {"width": width, "height": height}})
            yield ff
        finally:
            if ff is not None:
                ff.close()
            _stop(process)
            shutil.rmtree(profile, ignore_errors=True)

    def close(self) -> None:
        """Ends the session and quits the browser (browser.close; session.end alone leaves firefox running);
        launch() then makes sure the process group is gone."""
        try:
            self.command("browser.close", {}, timeout=5.0)
        except Exception:
            with contextlib.suppress(Exception):
                self.command("session.end", {}, timeout=5.0)
        with contextlib.suppress(Exception):
            self.ws.close()

    # -- the protocol -----------------------------------------------------------------------------------
    def command(self, method: str, params: dict[str, Any], timeout: float = 60.0) -> dict[str, Any]:
        """Sends one command and returns its result; events read meanwhile are kept (console errors)."""
        self._next_id += 1
        ident = self._next_id
        self.ws.send(json.dumps({"id": ident, "method": method, "params": params}))
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no answer to {method} in {timeout} s")
            message = json.loads(self.ws.recv(timeout=left))
            if message.get("type") == "event":
                self._event(message)
            elif message.get("id") == ident:
                if message.get("type") == "error":
                    raise BidiError(f"{method}: {message.get('error')}: {message.get('message')}")
                return dict(message["result"])

    def _event(self, message: dict[str, Any]) -> None:
        p = message["params"]
        if message.get("method") == "log.entryAdded":
            self.log.append(LogEntry(p.get("type", ""), p.get("level", ""), (p.get("text") or "")[:4000],
                                     json.dumps(p.get("stackTrace", {}))[:2000]))
        elif message.get("method") == "network.fetchError":
            self.failed_requests.append((p.get("request", {}).get("url", ""), p.get("errorText", "")))

    # -- what tests use ---------------------------------------------------------------------------------
    def navigate(self, url: str, timeout: float = 60.0) -> None:
        """Opens ``url`` and returns once the page has loaded (the load event)."""
        self.command("browsingContext.navigate", {"context": self.context, "url": url, "wait": "complete"}, timeout)

    def reload(self, timeout: float = 60.0) -> None:
        self.command("browsingContext.reload", {"context": self.context, "wait": "complete"}, timeout)

    def evaluate(self, expression: str, timeout: float = 60.0, frame: str | None = None) -> Any:
        """The value of a JavaScript expression in the page, or in one of its frames (a context id from frames();
        cross-origin too), as Python data; a promise is awaited."""
        target = {"context": frame or self.context}
        result = self.command("script.evaluate", {"expression": expression, "target": target, "awaitPromise": True,
                                                  "resultOwnership": "none"}, timeout)
        if result.get("type") == "exception":
            details = result.get("exceptionDetails", {})
            raise BidiError(f"{expression!r} threw: {details.get('text')}")
        return from_remote(result["result"])

    def wait_for_js(self, expression: str, timeout: float = 30.0, interval: float = 0.1, what: str = "",
                    frame: str | None = None) -> Any:
        """The first truthy value of ``expression`` (in the page or a frame), polled; AssertionError after
        ``timeout``."""
        deadline = time.monotonic() + timeout
        while True:
            value = self.evaluate(expression, frame=frame)
            if value:
                return value
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout} s waiting for {what or expression} in firefox")
            time.sleep(interval)

    def frames(self) -> dict[str, str]:
        """The page's frames (iframes, nested ones too), as {context id: URL}, for evaluate(frame=...)."""
        found: dict[str, str] = {}
        todo = self.command("browsingContext.getTree", {"root": self.context})["contexts"]
        while todo:
            node = todo.pop()
            if node["context"] != self.context:
                found[node["context"]] = node.get("url", "")
            todo.extend(node.get("children") or [])
        return found

    def screenshot(self, path: Path, clip: dict[str, float] | None = None, full_page: bool = False) -> bytes:
        """Writes a PNG of the viewport, the whole document, or a box (CSS px of the document) and returns it."""
        params: dict[str, Any] = {"context": self.context, "origin": "document" if full_page or clip else "viewport"}
        if clip is not None:
            params["clip"] = {"type": "box", **clip}
        png = base64.b64decode(self.command("browsingContext.captureScreenshot", params)["data"])
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(png)
        return png

    def box(self, selector: str) -> dict[str, float]:
        """The element's box in document coordinates (for screenshot clips)."""
        return dict(self.evaluate(f"""(() => {{ const r = document.querySelector({json.dumps(selector)})
            .getBoundingClientRect(); return {{ x: r.x + scrollX, y: r.y + scrollY, width: r.width,
            height: r.height }}; }})()"""))

    @property
    def console_errors(self) -> list[LogEntry]:
        """Errors logged so far: console.error calls and uncaught exceptions (drain first with evaluate)."""
        return [e for e in self.log if e.level == "error" or e.kind == "javascript"]


@contextlib.contextmanager
def virtual_display(width: int = 1920, height: int = 2400, timeout: float = 30.0) -> Iterator[str]:
    """An Xvfb X server on a free display number (Xvfb picks it: -displayfd), yielded as ":<n>", for a browser
    that needs a real window (WebGL); local connections only; its process group is ended afterwards.
    FileNotFoundError when Xvfb is not installed (apt-get install xvfb)."""
    if not XVFB.exists():
        raise FileNotFoundError(f"{XVFB} is missing: apt-get install xvfb")
    read_end, write_end = os.pipe()
    try:
        process = subprocess.Popen([str(XVFB), "-displayfd", str(write_end), "-nolisten", "tcp", "-screen", "0",
                                    f"{width}x{height}x24"], pass_fds=(write_end,), stdin=subprocess.DEVNULL,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    finally:
        os.close(write_end)
    try:
        # Xvfb writes the number once it accepts connections; end of file (no number) means it exited
        ready, _, _ = select.select([read_end], [], [], timeout)
        number = os.read(read_end, 64).decode().strip() if ready else ""
        if not number.isdigit():
            process.kill()
            _, err = process.communicate(timeout=5)
            raise RuntimeError(f"Xvfb did not start in {timeout} s (exit {process.returncode}):\n"
                               f"{err.decode(errors='replace')}")
        yield f":{number}"
    finally:
        os.close(read_end)
        _end_group(process, 5)
        if process.stderr is not None:
            process.stderr.close()


def from_remote(value: dict[str, Any]) -> Any:
    """A BiDi RemoteValue as Python data (objects and maps as dicts, arrays and sets as lists)."""
    kind = value.get("type")
    raw = value.get("value")
    if kind in ("undefined", "null"):
        return None
    if kind == "number":
        if isinstance(raw, str):
            return {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf, "-0": -0.0}[raw]
        return raw
    if kind in ("string", "boolean"):
        return raw
    if kind == "bigint":
        return int(str(raw))
    if kind in ("array", "set"):
        return [from_remote(v) for v in raw or []]
    if kind in ("object", "map"):
        return {(k if isinstance(k, str) else from_remote(k)): from_remote(v) for k, v in raw or []}
    return {"type": kind, **({"value": raw} if raw is not None else {})}  # nodes, functions...: as described


def _read_stderr(process: subprocess.Popen[bytes], lines: list[str], found: threading.Event) -> None:
    """Keeps the pipe drained (a full pipe would stall firefox) and tells when BiDi is listening."""
    assert process.stderr is not None
    for raw in process.stderr:
        line = raw.decode(errors="replace")
        lines.append(line)
        if LISTENING.search(line):
            found.set()


def _end_group(process: subprocess.Popen[bytes], grace: float) -> None:
    """SIGTERM to the process group, SIGKILL if the leader is still there after ``grace`` s."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, sig)
        try:
            process.wait(grace)
            return
        except subprocess.TimeoutExpired:
            continue


def _stop(process: subprocess.Popen[bytes]) -> None:
    """Waits briefly for the browser to close after session.end, then ends its process group."""
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:
        _end_group(process, 10)
    with contextlib.suppress(ProcessLookupError):  # content processes left behind by a crash
        os.killpg(process.pid, signal.SIGKILL)
