#!/usr/bin/env python3
"""A real `apo batch` run, its pages opened in headless Chromium.

usage: batch_in_browser.py APO MESH WORKDIR

Puts MESH (a real dataset mesh) into WORKDIR/scans under a hostile name and
beside a broken file, runs `apo batch` on the folder with small renders,
checks that it finishes with exit code 2 (one scan failed) and the summary
says so, then opens OUTDIR/index.html and the good scan's report.html with
browser_check.py (every image loads, no SEVERE browser log entry; the
screenshots stay in WORKDIR). Exits 0 when all is well, 1 otherwise.
"""

import json
import pathlib
import shutil
import subprocess
import sys

HOSTILE = "<img src=x onerror=alert(1)>"


def main(argv):
    if len(argv) != 4:
        print(__doc__, file=sys.stderr)
        return 1
    apo, mesh, work = pathlib.Path(argv[1]), pathlib.Path(argv[2]), pathlib.Path(argv[3])
    shutil.rmtree(work, ignore_errors=True)
    scans = work / "scans"
    (scans / "lab #1").mkdir(parents=True)
    good = scans / "lab #1" / (HOSTILE + mesh.suffix)
    shutil.copyfile(mesh, good)
    (scans / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n")
    out = work / "out"
    run = subprocess.run([str(apo), "batch", str(scans), "-o", str(out), "--faces", "1000", "--size", "256",
                          "--views", "4", "--frames", "1"], capture_output=True, text=True, timeout=600)
    if run.returncode != 2:
        print(f"apo batch exited with {run.returncode}, expected 2 (one broken scan):\n{run.stderr}", file=sys.stderr)
        return 1
    summary = json.loads((out / "summary.json").read_text())
    if (summary["succeeded"], summary["failed"]) != (1, 1):
        print(f"unexpected summary: {summary}", file=sys.stderr)
        return 1
    check = pathlib.Path(__file__).with_name("browser_check.py")
    for page, shot in ((out / "index.html", work / "index.png"),
                       (out / "lab #1" / good.name / "report.html", work / "report.png")):
        result = subprocess.run([sys.executable, str(check), str(page), str(shot)])
        if result.returncode != 0:
            print(f"{page}: the browser check failed", file=sys.stderr)
            return 1
    print(f"ok: {out / 'index.html'} and the report opened in Chromium; screenshots in {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
