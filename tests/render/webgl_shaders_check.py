#!/usr/bin/env python3
"""The APO pass's WebGL2 shaders (render.h webglApoShaders: the OSMesa shaders' own text as GLSL ES 3.00)
compiled, linked and drawn once in headless Chromium (SwiftShader).

usage: webgl_shaders_check.py PAGE.html

PAGE.html is written by write_webgl_shaders; it puts "ok" in its title, or the failing stage and the
browser's shader log. Exits 0 on "ok", 1 otherwise (also without chromium or chromedriver: this check
must not be skipped)."""

import os
import pathlib
import signal
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "report"))
from browser_check import CHROMEDRIVER, CHROMIUM, CheckFailed, Timeout, start_driver, stop  # noqa: E402

TIMEOUT_SECONDS = 60


def title_of(page, workdir, deadline):
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(path, os.X_OK):
            raise CheckFailed(f"{path} not found: install the Debian package {package} (setup.sh does)")
    driver, process = start_driver(workdir)
    try:
        driver.wait_ready(process, min(deadline, time.monotonic() + 20))
        driver.new_session(workdir / "profile")
        driver.request("POST", driver.session_path("/url"), {"url": page.as_uri()})
        while True:
            title = driver.execute("return document.title;")
            if title != "pending":
                return title
            if time.monotonic() > deadline:
                raise Timeout()
            time.sleep(0.1)
    finally:
        signal.alarm(0)
        driver.quit()
        stop(process)


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 1

    def on_alarm(signum, frame):
        raise Timeout()

    signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(TIMEOUT_SECONDS)
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="apo-webgl-check-"))
    try:
        title = title_of(pathlib.Path(argv[1]).resolve(), workdir, time.monotonic() + TIMEOUT_SECONDS - 5)
    except (CheckFailed, Timeout) as e:
        print(f"webgl_shaders_check: {e or 'timed out'}", file=sys.stderr)
        return 1
    if title != "ok":
        print(f"webgl_shaders_check: {title}", file=sys.stderr)
        return 1
    print("webgl_shaders_check: the APO pass's WebGL2 shaders compile, link and draw")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
