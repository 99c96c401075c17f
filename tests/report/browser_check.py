#!/usr/bin/env python3
"""Opens an HTML report in headless Chromium and checks that it renders.

usage: browser_check.py REPORT.html SCREENSHOT.png

Drives /usr/bin/chromedriver through its W3C WebDriver HTTP API with only the
Python standard library: opens file://REPORT, waits for the page to load,
checks that every <img> has loaded (complete and naturalWidth > 0; the broken
ones are listed by src) and that the browser log holds no SEVERE entry (a
missing image, a blocked resource, a script error), then saves a screenshot of
the whole page. Exits 0 when all is well, 1 with a message otherwise (also
when chromium or chromedriver is missing: this check must not be skipped).
chromedriver, and the browser with it, is always stopped; the whole check
gives up after 60 seconds.

CHROMEDRIVER and CHROMIUM in the environment override the two paths.
"""

import base64
import json
import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

CHROMEDRIVER = os.environ.get("CHROMEDRIVER", "/usr/bin/chromedriver")
CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
TIMEOUT_SECONDS = 60
WINDOW_WIDTH, WINDOW_HEIGHT = 1400, 1000
MAX_SCREENSHOT_HEIGHT = 20000  # pixels; longer pages are cut there


class CheckFailed(Exception):
    pass


class Timeout(Exception):
    pass


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class WebDriver:
    """The few W3C WebDriver commands this check needs."""

    def __init__(self, port):
        self.base = f"http://127.0.0.1:{port}"
        self.session = None

    def request(self, method, path, body=None, timeout=30):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.base + path, data=data, method=method,
                                     headers={"Content-Type": "application/json; charset=utf-8"})
        try:
            with urllib.request.urlopen(req, timeout=timeout) as response:
                payload = json.loads(response.read().decode() or "{}")
        except urllib.error.HTTPError as e:
            try:
                payload = json.loads(e.read().decode() or "{}")
            except ValueError:
                payload = {}
            value = payload.get("value") if isinstance(payload, dict) else None
            message = value.get("message", "") if isinstance(value, dict) else ""
            error = value.get("error", "") if isinstance(value, dict) else ""
            raise WebDriverError(e.code, error, message) from None
        return payload.get("value") if isinstance(payload, dict) else None

    def session_path(self, path):
        return f"/session/{self.session}{path}"

    def wait_ready(self, process, deadline):
        while time.monotonic() < deadline:
            if process.poll() is not None:
                raise CheckFailed(f"chromedriver exited with code {process.returncode} before it was ready")
            try:
                status = self.request("GET", "/status", timeout=2)
                if isinstance(status, dict) and status.get("ready"):
                    return
            except (OSError, WebDriverError):
                pass
            time.sleep(0.1)
        raise CheckFailed("chromedriver did not become ready")

    def new_session(self, user_data_dir, extra_args=()):
        args = [*extra_args, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                f"--user-data-dir={user_data_dir}", f"--window-size={WINDOW_WIDTH},{WINDOW_HEIGHT}"]
        capabilities = {"alwaysMatch": {
            "goog:chromeOptions": {"binary": CHROMIUM, "args": args},
            "goog:loggingPrefs": {"browser": "ALL"},
        }}
        value = self.request("POST", "/session", {"capabilities": capabilities}, timeout=45)
        self.session = value["sessionId"]

    def execute(self, script, args=None):
        return self.request("POST", self.session_path("/execute/sync"), {"script": script, "args": args or []})

    def browser_log(self):
        """The browser's console and network log entries since the last call."""
        errors = []
        for path in ("/se/log", "/log"):  # chromedriver's W3C extension, then the legacy JSON-wire endpoint
            try:
                return self.request("POST", self.session_path(path), {"type": "browser"})
            except WebDriverError as e:
                errors.append(f"{path}: {e}")
        raise CheckFailed("chromedriver offers no browser log (" + "; ".join(errors) + ")")

    def full_screenshot(self):
        """PNG bytes of the whole page: the viewport grown to the page's height."""
        size = self.execute("return [document.documentElement.scrollWidth, document.documentElement.scrollHeight];")
        width = max(WINDOW_WIDTH, int(size[0]))
        height = min(max(WINDOW_HEIGHT, int(size[1])), MAX_SCREENSHOT_HEIGHT)
        try:
            self.request("POST", self.session_path("/goog/cdp/execute"),
                         {"cmd": "Emulation.setDeviceMetricsOverride",
                          "params": {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False}})
            shot = self.request("POST", self.session_path("/goog/cdp/execute"),
                                {"cmd": "Page.captureScreenshot", "params": {"format": "png", "captureBeyondViewport": True}})
            return base64.b64decode(shot["data"])
        except (WebDriverError, KeyError, TypeError):
            # Without the DevTools passthrough: grow the window, then the W3C screenshot.
            self.request("POST", self.session_path("/window/rect"), {"width": width, "height": height})
            return base64.b64decode(self.request("GET", self.session_path("/screenshot")))

    def quit(self):
        if self.session is not None:
            try:
                self.request("DELETE", self.session_path(""), timeout=10)
            except (OSError, WebDriverError):
                pass
            self.session = None


class WebDriverError(Exception):
    def __init__(self, status, error, message):
        super().__init__(f"HTTP {status} {error}: {message.splitlines()[0] if message else ''}")


def start_driver(workdir):
    """chromedriver on a free port, logging to WORKDIR/chromedriver.log, in its own process group (so that
    the browser it starts is stopped with it by stop()); not yet ready."""
    port = free_port()
    with open(workdir / "chromedriver.log", "wb") as log:
        process = subprocess.Popen([CHROMEDRIVER, f"--port={port}"], stdout=log, stderr=subprocess.STDOUT,
                                   stdin=subprocess.DEVNULL, start_new_session=True)
    return WebDriver(port), process


def check(report, screenshot, workdir, deadline):
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(path, os.X_OK):
            raise CheckFailed(f"{path} not found: install the Debian package {package} (setup.sh does)")
    if not report.is_file():
        raise CheckFailed(f"{report}: no such file")

    log_path = workdir / "chromedriver.log"
    driver, driver_process = start_driver(workdir)
    try:
        driver.wait_ready(driver_process, min(deadline, time.monotonic() + 20))
        driver.new_session(workdir / "profile")
        driver.request("POST", driver.session_path("/window/rect"), {"width": WINDOW_WIDTH, "height": WINDOW_HEIGHT})
        driver.request("POST", driver.session_path("/url"), {"url": report.as_uri()})
        while driver.execute("return document.readyState;") != "complete":
            if time.monotonic() > deadline:
                raise Timeout()
            time.sleep(0.1)

        problems = []
        title = driver.execute("return document.title;")
        images = driver.execute(
            "return Array.from(document.images).map(i => ({src: i.getAttribute('src'), url: i.currentSrc, "
            "complete: i.complete, width: i.naturalWidth}));")
        broken = [i for i in images if not i["complete"] or not i["width"]]
        for image in broken:
            problems.append(f"broken image: src={image['src']!r} ({image['url']})")
        severe = [e for e in driver.browser_log() or [] if e.get("level") == "SEVERE"]
        for entry in severe:
            problems.append(f"browser log SEVERE: {entry.get('message', '')}")

        png = driver.full_screenshot()
        screenshot.parent.mkdir(parents=True, exist_ok=True)
        screenshot.write_bytes(png)
        print(f"browser_check: {report}: title {title!r}, {len(images)} images, {len(broken)} broken, "
              f"{len(severe)} SEVERE log entries; screenshot {screenshot} ({len(png)} bytes)")
        if problems:
            raise CheckFailed("\n".join(problems))
    finally:
        signal.alarm(0)  # the clean-up below has its own time limits
        driver.quit()
        stop(driver_process)
        if driver_process.returncode not in (0, -signal.SIGTERM, None) and log_path.exists():
            sys.stderr.write(log_path.read_text(errors="replace")[-2000:])


def stop(process):
    """Stops chromedriver and whatever it started (its process group)."""
    if process.poll() is None:
        try:
            os.killpg(process.pid, signal.SIGTERM)
            process.wait(timeout=5)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
    try:
        os.killpg(process.pid, signal.SIGKILL)  # the browser's processes, if any are left
    except (ProcessLookupError, PermissionError):
        pass
    if process.poll() is None:
        process.wait(timeout=5)


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 1
    report = pathlib.Path(argv[1]).resolve()
    screenshot = pathlib.Path(argv[2]).resolve()

    def on_alarm(signum, frame):
        raise Timeout()

    signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(TIMEOUT_SECONDS)
    deadline = time.monotonic() + TIMEOUT_SECONDS - 5
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="apo-browser-check-"))
    try:
        check(report, screenshot, workdir, deadline)
        return 0
    except CheckFailed as e:
        print(f"browser_check: FAILED: {report}:\n{e}", file=sys.stderr)
        return 1
    except Timeout:
        print(f"browser_check: FAILED: {report}: gave up after {TIMEOUT_SECONDS} s", file=sys.stderr)
        return 1
    except (OSError, WebDriverError, ValueError, KeyError, TypeError) as e:
        print(f"browser_check: FAILED: {report}: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    finally:
        signal.alarm(0)
        shutil.rmtree(workdir, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
