"""A small headless-Chromium driver over the DevTools protocol (tests only).

Chromium is started with a fresh profile and ``--remote-debugging-port=0``; the port is read
from the profile's ``DevToolsActivePort`` file and the page target is driven over its
websocket (``websocket-client``). Console errors, uncaught exceptions, log errors and every
network request that is not ``file:`` or ``data:`` are collected while a page loads.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync", "--no-first-run", "--no-default-browser-check",
                  "--disable-extensions", "--mute-audio", "--hide-scrollbars")


def chromium_path() -> str | None:
    """The Chromium executable (``VFMODEL_CHROMIUM`` or the Debian package's), or None."""
    for name in (os.environ.get("VFMODEL_CHROMIUM"), "chromium", "chromium-browser",
                 "google-chrome"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


@dataclass
class PageLoad:
    """What happened while a page loaded."""

    console_errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)


class Browser:
    """One Chromium process and its first page target."""

    def __init__(self, exe: str, profile: Path, width: int = 1280, height: int = 800) -> None:
        import websocket

        # Chromium leaves its singleton socket directory in TMPDIR when it is terminated
        # (three /tmp/org.chromium.Chromium.* per test run): a TMPDIR of its own, removed
        # on close (short: the socket path must fit a sockaddr_un, 108 bytes)
        self._tmp = tempfile.mkdtemp(prefix="vfm-cdp-")
        tmp = self._tmp
        self.proc = subprocess.Popen(
            [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0",
             f"--window-size={width},{height}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env={**os.environ, "TMPDIR": tmp})
        port_file = profile / "DevToolsActivePort"
        deadline = time.monotonic() + 30
        while not (port_file.is_file() and port_file.read_text().strip()):
            if time.monotonic() > deadline or self.proc.poll() is not None:
                self.close()
                raise RuntimeError("Chromium did not start its DevTools endpoint")
            time.sleep(0.05)
        port = int(port_file.read_text().split()[0])
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
            targets = json.loads(r.read())
        page = next(t for t in targets if t.get("type") == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=30,
                                              suppress_origin=True)
        self._id = 0
        self.events: list[dict[str, Any]] = []
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.call(f"{domain}.enable")
        self.call("Emulation.setDeviceMetricsOverride", width=width, height=height,
                  deviceScaleFactor=1, mobile=False)

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        """Send a command and return its result (events seen meanwhile are kept)."""
        self._id += 1
        self.ws.send(json.dumps({"id": self._id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self._id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return dict(msg.get("result", {}))
            if "method" in msg:
                self.events.append(msg)

    def wait_event(self, method: str, timeout: float = 30) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for i, e in enumerate(self.events):
                if e["method"] == method:
                    return self.events.pop(i)
            msg = json.loads(self.ws.recv())
            if "method" in msg:
                self.events.append(msg)
        raise TimeoutError(method)

    def load(self, path: Path) -> PageLoad:
        """Navigate to a local file, wait for the load event, report errors and requests."""
        self.events.clear()
        self.call("Page.navigate", url=path.resolve().as_uri())
        self.wait_event("Page.loadEventFired")
        self.evaluate("new Promise(r => setTimeout(r, 100))")  # let late errors arrive
        out = PageLoad()
        for e in self.events:
            m, p = e["method"], e.get("params", {})
            if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                out.console_errors.append(" ".join(str(a.get("value", a.get("description")))
                                                   for a in p.get("args", [])))
            elif m == "Runtime.exceptionThrown":
                out.console_errors.append(str(p.get("exceptionDetails", {})))
            elif m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
                out.console_errors.append(str(p["entry"].get("text")))
            elif m == "Network.requestWillBeSent":
                out.requests.append(str(p.get("request", {}).get("url", "")))
        return out

    def evaluate(self, expression: str) -> Any:
        """Value of a JavaScript expression (promises awaited, results by value)."""
        res = self.call("Runtime.evaluate", expression=expression, returnByValue=True,
                        awaitPromise=True)
        if "exceptionDetails" in res:
            raise RuntimeError(f"JavaScript failed: {res['exceptionDetails']}")
        return res.get("result", {}).get("value")

    def screenshot(self, path: Path) -> Path:
        """PNG of the first screen (the viewport)."""
        res = self.call("Page.captureScreenshot", format="png")
        path.write_bytes(base64.b64decode(res["data"]))
        return path

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.ws.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self._tmp, ignore_errors=True)


@contextlib.contextmanager
def browser(profile: Path) -> Iterator[Browser]:
    exe = chromium_path()
    if exe is None:
        raise RuntimeError("Chromium not found")
    b = Browser(exe, profile)
    try:
        yield b
    finally:
        b.close()


PAGE_FACTS_JS = """(() => {
  const vh = window.innerHeight;
  const imgs = Array.from(document.querySelectorAll('img[src]'));
  const rect = el => el ? el.getBoundingClientRect().toJSON() : null;
  return {
    viewport: [window.innerWidth, vh],
    broken: imgs.filter(i => !i.complete || i.naturalWidth === 0).map(i => i.alt),
    n_images: imgs.length,
    external: imgs.filter(i => !i.src.startsWith('data:')).map(i => i.src)
      .concat(Array.from(document.querySelectorAll('link[href],script[src]'))
              .map(e => e.href || e.src)),
    summary: rect(document.getElementById('summary')),
    summary_table: rect(document.querySelector('#summary table')),
    verdict: (document.querySelector('#summary .verdict') || {}).innerText,
    key_image: rect(document.querySelector('#summary img')),
    key_image_size: (() => { const i = document.querySelector('#summary img');
                             return i ? [i.naturalWidth, i.naturalHeight] : null; })(),
    numbers: Array.from(document.querySelectorAll('span.num[data-key]')).map(s => ({
      key: JSON.parse(s.dataset.key), unit: s.dataset.unit,
      scale: parseFloat(s.dataset.scale || '1'), text: s.innerText})),
    text: document.body.innerText,
  };
})()"""
