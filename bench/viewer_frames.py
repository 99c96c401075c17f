#!/usr/bin/env python3
"""Frame time of the report's interactive viewer in headless Chromium (SwiftShader's WebGL2, on the CPU).

usage: viewer_frames.py VIEWER.html [FRAMES]

Opens the page at its canvas size (1024 x 768), and for each mode (m with the APO filtered and unfiltered, m
alone, M, the heat map) and each of the first views times FRAMES frames (default 5; each frame drawn and a
pixel read back, so the rasteriser's work is in it) through window.apoViewer; prints a markdown row per mode
with the median over views of each view's median, in milliseconds, and the page's load time."""

import json
import pathlib
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests" / "report"))
from browser_check import start_driver, stop  # noqa: E402

VIEWS = 4
SOFTWARE_WEBGL = ["--enable-unsafe-swiftshader", "--use-angle=swiftshader"]


def main(argv):
    page = pathlib.Path(argv[1]).resolve()
    frames = int(argv[2]) if len(argv) > 2 else 5
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="apo-viewer-frames-"))
    driver, process = start_driver(workdir)
    try:
        driver.wait_ready(process, time.monotonic() + 20)
        driver.new_session(workdir / "profile", SOFTWARE_WEBGL)
        start = time.monotonic()
        driver.request("POST", driver.session_path("/url"), {"url": page.as_uri()})
        while not driver.execute("return !!(window.apoViewer);"):
            time.sleep(0.05)
        loaded = time.monotonic() - start
        state = driver.execute("return {ready: window.apoViewer.ready, error: window.apoViewer.error || ''};")
        if not state["ready"]:
            print(f"viewer_frames: {page}: not ready: {state['error']}", file=sys.stderr)
            return 1
        views = min(VIEWS, driver.execute("return window.apoViewer.views;"))
        print(f"{page}: {page.stat().st_size} bytes, ready in {loaded:.2f} s")
        print("| mode | ms per frame at 1024 x 768 (median over views " + f"0-{views - 1}) |")
        print("|---|---|")
        for label, mode, filtering in (("m with the APO, filtered", "apo", True), ("m with the APO, unfiltered", "apo", False),
                                       ("m alone", "coarse", None), ("M", "detail", None), ("heat map", "heat", True)):
            times = []
            for view in range(views):
                times.append(driver.execute(
                    "const v = window.apoViewer; if (arguments[2] !== null) v.setFiltering(arguments[2]);"
                    "v.setMode(arguments[0]); v.setView(arguments[1]); return v.timeFrames(arguments[3]);",
                    [mode, view, filtering, frames]))
            times.sort()
            print(f"| {label} | {times[len(times) // 2]:.1f} |")
        return 0
    finally:
        driver.quit()
        stop(process)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
