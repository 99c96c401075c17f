#!/usr/bin/env python3
"""The report's interactive viewer (viewer.html) checked in headless Chromium (SwiftShader's WebGL2)
against the OSMesa renders of the same scene.

usage: viewer_check.py DIR [FRAME_SIZE]

DIR is written by write_viewer_check: viewer.html (a bumpy sphere under a hostile scan name), the OSMesa
passes' normal buffers of m with the APO at the 14 standard views (expected_{plain,filtered}.f32, rows from
the top, float32 RGBA) and expected.json ({size, views, name}). The check:

1. opens viewer.html; the viewer must be ready (its shaders, all from render/, compiled and linked), the
   page's title must be the hostile name as text, and no element may have come from it;
2. per view, unfiltered and filtered, reads the viewer's normal buffer of m with the APO at the same view
   and size (window.apoViewer.normals) and compares it with OSMesa's on the pixels both cover: at least
   99% within 1 degree, over all views and in each view; the pixels beyond are counted by kind (at the
   silhouette: a pixel with an uncovered neighbour in either buffer; inside) and pixels covered by one
   buffer only are counted too (at most 1% of the covered ones);
3. no SEVERE entry in the browser log (a shader error, a script error);
4. times frames of each mode at 1024 x 768 (printed, for docs/benchmarks.md; not judged);
5. opens the page again in a browser without WebGL (--disable-3d-apis): the viewer must say why and show
   the static views, every image loaded.

Exits 0 when all holds, 1 with the figures otherwise (also without chromium or chromedriver).
"""

import base64
import json
import math
import os
import pathlib
import signal
import struct
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from browser_check import CHROMEDRIVER, CHROMIUM, CheckFailed, Timeout, start_driver, stop  # noqa: E402

TIMEOUT_SECONDS = 240
WITHIN_DEGREES = 1.0
SHARE_WITHIN = 0.99
MOST_COVERAGE_MISMATCH = 0.01
TIMED_FRAMES = 3
SOFTWARE_WEBGL = ["--enable-unsafe-swiftshader", "--use-angle=swiftshader"]


def angle_degrees(a, b):
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    return math.degrees(math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]))


def compare_view(expected, got, size):
    """Figures of one view: expected rows from the top, got rows from the bottom (GL)."""
    def pixel(buffer, x, y_top, flipped):
        row = size - 1 - y_top if flipped else y_top
        i = 4 * (row * size + x)
        return buffer[i:i + 4]

    covered = lambda p: p[3] > 0.5  # noqa: E731
    figures = {"both": 0, "within": 0, "edge_beyond": 0, "inside_beyond": 0, "one_only": 0, "worst": 0.0}
    for y in range(size):
        for x in range(size):
            e, g = pixel(expected, x, y, False), pixel(got, x, y, True)
            if covered(e) != covered(g):
                figures["one_only"] += 1
                continue
            if not covered(e):
                continue
            figures["both"] += 1
            degrees = angle_degrees(e, g)
            figures["worst"] = max(figures["worst"], degrees)
            if degrees <= WITHIN_DEGREES:
                figures["within"] += 1
                continue
            edge = any(not (0 <= x + dx < size and 0 <= y + dy < size)
                       or not covered(pixel(expected, x + dx, y + dy, False))
                       or not covered(pixel(got, x + dx, y + dy, True))
                       for dx in (-1, 0, 1) for dy in (-1, 0, 1))
            figures["edge_beyond" if edge else "inside_beyond"] += 1
    return figures


def open_page(driver, page, deadline):
    driver.request("POST", driver.session_path("/url"), {"url": page.as_uri()})
    while True:
        state = driver.execute("return window.apoViewer ? {ready: window.apoViewer.ready, "
                               "error: window.apoViewer.error || ''} : null;")
        if state is not None:
            return state
        if time.monotonic() > deadline:
            raise Timeout()
        time.sleep(0.1)


def severe_entries(driver):
    return [e.get("message", "") for e in driver.browser_log() or [] if e.get("level") == "SEVERE"]


def check_viewer(driver, directory, expected, deadline):
    page = directory / "viewer.html"
    state = open_page(driver, page, deadline)
    if not state["ready"]:
        raise CheckFailed(f"the viewer is not ready: {state['error']}")
    problems = []
    title = driver.execute("return document.title;")
    if title != expected["name"] + ": interactive view":
        problems.append(f"title {title!r}: the scan's name did not reach the page as text")
    injected = driver.execute("return document.querySelectorAll('img[src=x], body > img').length;")
    if injected:
        problems.append(f"{injected} element(s) made from the scan's name")

    size, views = expected["size"], expected["views"]
    for kind in ("plain", "filtered"):
        raw = (directory / f"expected_{kind}.f32").read_bytes()
        per_view = 4 * size * size
        values = struct.unpack(f"<{len(raw) // 4}f", raw)
        totals = {"both": 0, "within": 0, "edge_beyond": 0, "inside_beyond": 0, "one_only": 0, "worst": 0.0}
        for view in range(views):
            got_b64 = driver.execute("return window.apoViewer.normals(arguments[0], arguments[1], 'apo', "
                                     "{filtering: arguments[2], mipmapping: true});", [view, size, kind == "filtered"])
            got_bytes = base64.b64decode(got_b64)
            got = struct.unpack(f"<{len(got_bytes) // 4}f", got_bytes)
            figures = compare_view(values[view * per_view:(view + 1) * per_view], got, size)
            share = figures["within"] / max(figures["both"], 1)
            print(f"viewer_check: {kind} view {view:2d}: {figures['both']} pixels, {100 * share:.3f}% within "
                  f"{WITHIN_DEGREES} degree; beyond: {figures['edge_beyond']} at the silhouette, "
                  f"{figures['inside_beyond']} inside; worst {figures['worst']:.3f} degrees; "
                  f"covered by one only: {figures['one_only']}")
            if figures["both"] == 0 or share < SHARE_WITHIN:
                problems.append(f"{kind} view {view}: {100 * share:.3f}% of {figures['both']} pixels within "
                                f"{WITHIN_DEGREES} degree")
            for key in totals:
                totals[key] = max(totals[key], figures[key]) if key == "worst" else totals[key] + figures[key]
        share = totals["within"] / max(totals["both"], 1)
        mismatch = totals["one_only"] / max(totals["both"], 1)
        print(f"viewer_check: {kind}: {totals['both']} pixels over {views} views, {100 * share:.3f}% within "
              f"{WITHIN_DEGREES} degree; beyond: {totals['edge_beyond']} at the silhouette, {totals['inside_beyond']} "
              f"inside; covered by one only: {totals['one_only']} ({100 * mismatch:.3f}%)")
        if share < SHARE_WITHIN:
            problems.append(f"{kind}: {100 * share:.3f}% within {WITHIN_DEGREES} degree")
        if mismatch > MOST_COVERAGE_MISMATCH:
            problems.append(f"{kind}: {100 * mismatch:.3f}% of pixels covered by one buffer only")
        if time.monotonic() > deadline:
            raise Timeout()

    problems += check_interaction(driver)
    for mode in ("apo", "coarse", "detail", "heat"):
        driver.execute("window.apoViewer.setMode(arguments[0]); window.apoViewer.setView(0);", [mode])
        milliseconds = driver.execute("return window.apoViewer.timeFrames(arguments[0]);", [TIMED_FRAMES])
        print(f"viewer_check: frame time at 1024 x 768, view 0, {mode}: {milliseconds:.1f} ms "
              f"(median of {TIMED_FRAMES})")
    gl_error = driver.execute("return window.apoViewer.glError();")
    if gl_error:
        problems.append(f"WebGL error {gl_error}")
    problems += [f"browser log SEVERE: {m}" for m in severe_entries(driver)]
    return problems


def check_interaction(driver):
    """A drag orbits (the eye moves, its distance to the target stays), the wheel zooms, shift-drag pans,
    the light moves the shading, and a view's button restores the view exactly."""
    problems = []
    script = """
const canvas = document.getElementById('canvas'), v = window.apoViewer;
const distance = c => Math.hypot(c.eye[0] - c.target[0], c.eye[1] - c.target[1], c.eye[2] - c.target[2]);
const drag = (shift) => {
  const at = (x, y, type) => canvas.dispatchEvent(new PointerEvent(type, {clientX: x, clientY: y, button: 0,
      shiftKey: shift, pointerId: 1, bubbles: true}));
  at(300, 300, 'pointerdown'); at(360, 330, 'pointermove'); at(360, 330, 'pointerup');
};
const pixels = () => { const c = document.createElement('canvas'); c.width = 64; c.height = 48;
  const g = c.getContext('2d'); g.drawImage(canvas, 0, 0, 64, 48); return Array.from(g.getImageData(0, 0, 64, 48).data); };
v.setMode('apo'); v.setView(0); v.timeFrames(1);
const start = v.camera();
drag(false);
const orbited = v.camera();
canvas.dispatchEvent(new WheelEvent('wheel', {deltaY: 500, bubbles: true, cancelable: true}));
const zoomed = v.camera();
drag(true);
const panned = v.camera();
v.setView(0); v.timeFrames(1);
const headlit = pixels();
document.getElementById('headlight').click(); v.timeFrames(1);
const lit = pixels();
document.getElementById('headlight').click();
v.setView(0);
const back = v.camera();
let changed = 0; for (let i = 0; i < lit.length; ++i) if (lit[i] !== headlit[i]) ++changed;
return {start, orbited, zoomed, panned, back, changed,
        d0: distance(start), d1: distance(orbited), d2: distance(zoomed), d3: distance(panned)};
"""
    r = driver.execute(script)
    moved = lambda a, b: max(abs(x - y) for x, y in zip(a, b)) > 1e-4  # noqa: E731
    if not moved(r["start"]["eye"], r["orbited"]["eye"]) or abs(r["d1"] - r["d0"]) > 1e-4 * r["d0"]:
        problems.append(f"a drag does not orbit: {r['start']} -> {r['orbited']}")
    if not r["d2"] > 1.5 * r["d1"]:
        problems.append(f"the wheel does not zoom out: distance {r['d1']} -> {r['d2']}")
    if not moved(r["zoomed"]["target"], r["panned"]["target"]) or abs(r["d3"] - r["d2"]) > 1e-4 * r["d2"]:
        problems.append(f"shift-drag does not pan: {r['zoomed']} -> {r['panned']}")
    if r["back"] != r["start"]:
        problems.append(f"view 0's button does not restore it: {r['back']} != {r['start']}")
    if r["changed"] == 0:
        problems.append("moving the light off the headlight changes nothing")
    print(f"viewer_check: interaction: orbit keeps the distance {r['d0']:.4f}, zoom to {r['d2']:.4f}, pan moves the "
          f"target; {r['changed']} colour values change with the light; view 0 restored")
    return problems


def check_fallback(driver, directory, deadline):
    state = open_page(driver, directory / "viewer.html", deadline)
    if state["ready"]:
        return ["without WebGL the viewer says it is ready"]
    problems = []
    shown = driver.execute("return {why: document.getElementById('why').textContent, "
                           "hidden: document.getElementById('fallback').hidden, "
                           "images: Array.from(document.querySelectorAll('#fallback img')).map("
                           "i => ({src: i.getAttribute('src'), ok: i.complete && i.naturalWidth > 0}))};")
    deadline_images = time.monotonic() + 10
    while not all(i["ok"] for i in shown["images"]) and time.monotonic() < deadline_images:
        time.sleep(0.2)
        shown["images"] = driver.execute("return Array.from(document.querySelectorAll('#fallback img')).map("
                                         "i => ({src: i.getAttribute('src'), ok: i.complete && i.naturalWidth > 0}));")
    print(f"viewer_check: without WebGL: {shown['why']!r}, {len(shown['images'])} static views")
    if shown["hidden"] or "WebGL2" not in shown["why"]:
        problems.append(f"without WebGL the fallback is not shown with its reason ({shown['why']!r})")
    if len(shown["images"]) == 0:
        problems.append("without WebGL no static view is shown")
    problems += [f"static view not loaded: {i['src']}" for i in shown["images"] if not i["ok"]]
    return problems


def session(workdir, extra_args, work):
    driver, process = start_driver(workdir)
    try:
        driver.wait_ready(process, time.monotonic() + 20)
        driver.new_session(workdir / f"profile{len(extra_args)}", extra_args)
        return work(driver)
    finally:
        driver.quit()
        stop(process)


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 1
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(path, os.X_OK):
            print(f"viewer_check: {path} not found: install the Debian package {package} (setup.sh does)",
                  file=sys.stderr)
            return 1

    def on_alarm(signum, frame):
        raise Timeout()

    signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(TIMEOUT_SECONDS)
    deadline = time.monotonic() + TIMEOUT_SECONDS - 10
    directory = pathlib.Path(argv[1]).resolve()
    expected = json.loads((directory / "expected.json").read_text())
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="apo-viewer-check-"))
    try:
        problems = session(workdir, SOFTWARE_WEBGL, lambda d: check_viewer(d, directory, expected, deadline))
        problems += session(workdir, ["--disable-3d-apis"], lambda d: check_fallback(d, directory, deadline))
    except (CheckFailed, Timeout) as e:
        print(f"viewer_check: FAILED: {e or 'timed out'}", file=sys.stderr)
        return 1
    finally:
        signal.alarm(0)
    if problems:
        print("viewer_check: FAILED:\n" + "\n".join(problems), file=sys.stderr)
        return 1
    print("viewer_check: the viewer draws what the OSMesa renders draw, and falls back without WebGL")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
