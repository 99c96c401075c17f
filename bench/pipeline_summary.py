#!/usr/bin/env python3
"""Summary of an `apo batch` output folder, from its manifests, as markdown.

    python3 bench/pipeline_summary.py OUTDIR [BASELINE_OUTDIR]

Per-scan times and memory, the slowest scans, the failures with their
reasons, and how the APO compares with m's own normals (render.json's
overall mean angular error), split by whether simplification reduced the
mesh (when M is m, there is nothing for the APO to add). With a second
folder (the same scans under other options), the APO's error in both.
"""
import json
import pathlib
import statistics
import sys


def manifests(root):
    for path in sorted(root.rglob("manifest.json")):
        yield str(path.parent.relative_to(root)), json.loads(path.read_text())


def angles(manifest):
    overall = manifest["results"]["render"]["overall"]
    return overall["apo"]["mean"], overall["baseline"]["mean"]


def was_simplified(manifest):
    faces = manifest["results"]["simplify"]["faces"]
    return faces["out"] < faces["in"]


def main():
    root = pathlib.Path(sys.argv[1])
    other = dict(manifests(pathlib.Path(sys.argv[2]))) if len(sys.argv) > 2 else {}
    succeeded = [(name, m) for name, m in manifests(root) if m.get("status") == "succeeded"]
    failed = [(name, m) for name, m in manifests(root) if m.get("status") != "succeeded"]
    totals = [sum(s["seconds"] for s in m["stages"]) for _, m in succeeded]
    peaks = [max(s["peak_memory_bytes"] for s in m["stages"]) for _, m in succeeded]
    print(f"{len(succeeded)} succeeded, {len(failed)} failed. Per succeeded scan: median {statistics.median(totals):.1f} s, "
          f"mean {statistics.mean(totals):.1f} s, max {max(totals):.1f} s, sum {sum(totals):.0f} s; "
          f"peak memory at most {max(peaks) >> 20} MiB.")
    print()
    stages = [s["name"] for s in succeeded[0][1]["stages"]]
    print("Slowest scans (seconds per stage):")
    print()
    print("| scan | input MiB | " + " | ".join(stages) + " | total | peak MiB | APO / m alone (deg) |")
    print("|---|---|" + "---|" * (len(stages) + 3))
    slowest = sorted(zip(succeeded, totals, peaks), key=lambda row: -row[1])[:10]
    for (name, m), total, peak in slowest:
        apo, bare = angles(m)
        cells = " | ".join(f"{s['seconds']:.1f}" if s["status"] == "succeeded" else s["status"] for s in m["stages"])
        print(f"| {name} | {m['input']['bytes'] / 2**20:.1f} | {cells} | {total:.1f} | {peak >> 20} | {apo:.2f} / {bare:.2f} |")
    print()
    print("Failed scans:")
    print()
    print("| scan | stage | reason |")
    print("|---|---|---|")
    for name, m in failed:
        error = m.get("error") or {}
        message = str(error.get("message", "")).split(": ", 1)[-1].replace("|", "/")
        print(f"| {name} | {error.get('stage', '?')} | {message} |")
    print()
    for label, group in (("simplified (m has fewer faces than M)", [x for x in succeeded if was_simplified(x[1])]),
                         ("not simplified (M had at most the target's faces: m is M)",
                          [x for x in succeeded if not was_simplified(x[1])])):
        if not group:
            continue
        apo = [angles(m)[0] for _, m in group]
        bare = [angles(m)[1] for _, m in group]
        better = sum(1 for a, b in zip(apo, bare) if a < b)
        line = (f"- {label}: {len(group)} scans; APO mean error median {statistics.median(apo):.2f} deg against "
                f"{statistics.median(bare):.2f} for m alone; the APO is closer on {better} of {len(group)}")
        if other:
            before = [angles(other[name])[0] for name, _ in group if name in other and other[name].get("status") == "succeeded"]
            if before:
                line += f" (in the other folder: median {statistics.median(before):.2f} deg)"
        print(line + ".")
        # Point scans are judged against their own points too (a points-baked
        # APO follows the scan, not M): the truth each scan has.
        judged = [m["results"]["render"].get("against_scan") for _, m in group]
        truth_better = sum(1 for (a, b), scan in zip(zip(apo, bare), judged)
                           if (scan["apo_filtered"]["mean"] < scan["m"]["mean"] if scan else a < b))
        points_kept = sum(1 for _, m in group
                          if m["results"]["bake"].get("detail_source", {}).get("chosen") == "points")
        print(f"  Against each scan's own points for point scans ({sum(1 for j in judged if j)}; baked from the "
              f"points: {points_kept}) and against M for meshes: the APO is closer than m alone on {truth_better} of "
              f"{len(group)}.")


if __name__ == "__main__":
    main()
