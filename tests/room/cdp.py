"""A small driver of headless Chromium over the DevTools protocol on a pipe
(``--remote-debugging-pipe``: NUL-terminated JSON messages, the browser reading fd 3
and writing fd 4), for page tests that must run in real time: scroll a page, then wait
for what the scroll loads (virtual time does not always run a scripted scroll's
intersection observers)."""
from __future__ import annotations

import json
import os
import select
import subprocess
import time


class Browser:
    """``with Browser(CHROMIUM, size=(w, h)) as b: b.open(url); b.run("...js...")``."""

    def __init__(self, chromium: str, *, size=(800, 600), timeout: float = 60.0):
        self.timeout = timeout
        to_browser_r, self._w = os.pipe()
        self._r, from_browser_w = os.pipe()

        def fds():  # the browser's end of each pipe at fd 3 (commands) and fd 4 (replies); the
            a, b = os.dup(to_browser_r), os.dup(from_browser_w)  # copies first: either may be 3 or 4
            os.dup2(a, 3)
            os.dup2(b, 4)
        self.proc = subprocess.Popen([chromium, "--headless=new", "--no-sandbox", "--hide-scrollbars",
                                      "--remote-debugging-pipe", f"--window-size={size[0]},{size[1]}",
                                      "about:blank"], preexec_fn=fds, pass_fds=(3, 4),  # kept past preexec_fn
                                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._buf, self._id, self.session = b"", 0, None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=30)
        for fd in (self._w, self._r):
            try:
                os.close(fd)
            except OSError:
                pass

    def call(self, method: str, params: dict | None = None, *, session: bool = True) -> dict:
        """Send one command and wait for its reply (events on the way are dropped)."""
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        end = time.monotonic() + self.timeout
        while True:
            while b"\0" not in self._buf:
                left = end - time.monotonic()
                if left <= 0 or not select.select([self._r], [], [], left)[0]:  # never a read that blocks for ever
                    raise TimeoutError(f"no reply to {method}")
                chunk = os.read(self._r, 1 << 16)
                if not chunk:
                    raise RuntimeError("the browser went away")
                self._buf += chunk
            raw, self._buf = self._buf.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def open(self, url: str) -> None:
        """A new tab at ``url``, attached (later calls go to it)."""
        target = self.call("Target.createTarget", {"url": url}, session=False)["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        end = time.monotonic() + self.timeout
        while self.run("document.readyState === 'complete' && location.href") != url:  # loaded, not about:blank
            if time.monotonic() > end:
                raise TimeoutError(f"{url} did not load")
            time.sleep(0.02)

    def run(self, script: str):
        """The value of a JavaScript expression (awaited when it is a promise)."""
        r = self.call("Runtime.evaluate", {"expression": script, "awaitPromise": True, "returnByValue": True})
        if "exceptionDetails" in r:
            raise RuntimeError(f"the page's script failed: {r['exceptionDetails']}")
        return r["result"].get("value")
