"""Headless Chromium for the tests of HTML pages: the binary (`.ci/run` installs Debian's ``chromium``), the
flags that keep it off the network and out of the user's profile, one call of it, and a `Browser` that
clicks."""

from __future__ import annotations

import json
import shutil
import subprocess
import time
import urllib.request
from pathlib import Path

import pytest

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
)


def chromium_binary() -> str:
    """Path of ``chromium`` (or ``chromium-browser``); the calling test skips without it."""
    found = next(
        (shutil.which(name) for name in ("chromium", "chromium-browser") if shutil.which(name)), None
    )
    if found is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium, as .ci/run does)")
    return found


def run_chromium(page: Path, profile: Path, *options: str) -> str:
    """Run Chromium on ``page`` with ``options`` (``--dump-dom``, ``--print-to-pdf=...``) and a fresh
    profile folder; its standard output."""
    command = [chromium_binary(), *FLAGS, f"--user-data-dir={profile}", *options, page.as_uri()]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, check=True).stdout


class Browser:
    """Headless Chromium driven over the DevTools protocol (``websocket-client``), for tests that click: a
    page is loaded, an element is clicked where it is drawn, and the page it leads to is read."""

    def __init__(self, profile: Path) -> None:
        import websocket

        command = [chromium_binary(), *FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0"]
        self.process = subprocess.Popen(
            [*command, "about:blank"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        port_file = profile / "DevToolsActivePort"
        deadline = time.monotonic() + 60
        while not (port_file.is_file() and port_file.read_text().count("\n") >= 1):
            if time.monotonic() > deadline or self.process.poll() is not None:
                self.close()
                raise RuntimeError("Chromium did not open its DevTools port")
            time.sleep(0.1)
        port = int(port_file.read_text().splitlines()[0])
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as answer:
            page = next(target for target in json.load(answer) if target["type"] == "page")
        self.socket = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=60)
        self.calls = 0

    def call(self, method: str, **params: object) -> dict:
        """One DevTools command's result (events in between are skipped)."""
        self.calls += 1
        self.socket.send(json.dumps({"id": self.calls, "method": method, "params": params}))
        while True:
            message = json.loads(self.socket.recv())
            if message.get("id") == self.calls:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]

    def evaluate(self, expression: str) -> object:
        """The value of a JavaScript expression in the page."""
        return self.call("Runtime.evaluate", expression=expression, returnByValue=True)["result"].get("value")

    def open(self, url: str) -> None:
        """Load ``url`` and wait until it is complete."""
        self.call("Page.navigate", url=url)
        self.wait_for(f"location.href === {json.dumps(url)} && document.readyState === 'complete'")

    def wait_for(self, condition: str, seconds: float = 30.0) -> None:
        """Wait until a JavaScript condition holds; a page that is navigating away meanwhile (the condition
        asked of a page being replaced) is asked again once the next one is there."""
        deadline = time.monotonic() + seconds
        while not self._holds(condition):
            if time.monotonic() > deadline:
                raise TimeoutError(condition)
            time.sleep(0.1)

    def _holds(self, condition: str) -> bool:
        try:
            return bool(self.evaluate(condition))
        except RuntimeError as error:
            if "navigated or closed" in str(error) or "Cannot find context" in str(error):
                return False
            raise

    def click(self, selector: str) -> None:
        """Click the middle of the first element ``selector`` matches, as a mouse would."""
        box = self.evaluate(
            f"(() => {{ const e = document.querySelector({json.dumps(selector)}); e.scrollIntoView(); "
            "const r = e.getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; })()"
        )
        for kind in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=kind, x=box[0], y=box[1], button="left", clickCount=1)

    def close(self) -> None:
        """End Chromium."""
        self.process.kill()
        self.process.wait()
