#!/usr/bin/env bash
# `apo batch` end to end (issue 6) over every scan of datasets/ plus a few
# broken files, then killed and resumed:
#   1. the batch over OUTDIR/scans (links to every file of datasets/ that has
#      a scan extension, at the same relative paths, plus four broken files),
#      -j 1 (each scan gets both cores), --scan-timeout 300;
#   2. a second batch over a subset (the broken files and the first 12 scans
#      by path) into another folder, killed with SIGKILL after 20 s and after
#      40 s, then run to the end: its m.ply / M.ply / scan.apo / texture.png
#      must equal the first batch's for every scan that succeeded;
#   3. a markdown table of the first batch: per scan, its size, status and
#      per-stage seconds and peak memory, from the manifests;
#   4. its summary (bench/pipeline_summary.py): times, the slowest scans,
#      the failures, and the APO against m alone.
# Extra batch options (e.g. --no-filter) go in APO_OPTIONS.
# Usage (after the README's setup and build): bash bench/pipeline_bench.sh [OUTDIR]
# Takes about 13-20 minutes on this machine and writes about 25 GB under
# OUTDIR (23 GB of runs, renders and reports for the first batch): remove
# it after reading the tables.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/pipeline}
mkdir -p "$out/bin"
cp build/apo build/apo-engine build/apo-pcl.so "$out/bin/"
apo=$out/bin/apo
options=(--scan-timeout 300 ${APO_OPTIONS:-})

# ---- The scan folder ----------------------------------------------------------
rm -rf "$out/scans"
mkdir -p "$out/scans"
while IFS= read -r -d '' file; do
  relative=${file#datasets/}
  mkdir -p "$out/scans/$(dirname "$relative")"
  ln -s "$(realpath "$file")" "$out/scans/$relative"
done < <(find datasets -type f \( -iname '*.ply' -o -iname '*.pcd' -o -iname '*.xyz' -o -iname '*.xyzn' -o -iname '*.pts' \
  -o -iname '*.pwn' -o -iname '*.off' -o -iname '*.obj' -o -iname '*.stl' \) -print0)
mkdir -p "$out/scans/broken"
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n' \
  >"$out/scans/broken/huge_count.ply"
printf 'OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 9\n' >"$out/scans/broken/bad_index.off"
printf 'VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA ascii\n1 2 3\n' \
  >"$out/scans/broken/short.pcd"
: >"$out/scans/broken/empty.xyz"
echo "scans: $(find "$out/scans" \( -type f -o -type l \) | wc -l) files ($(find "$out/scans/broken" -type f | wc -l) broken)"

# ---- 1. The batch ---------------------------------------------------------------
rm -rf "$out/first"
start=$(date +%s)
set +e
"$apo" batch "$out/scans" -o "$out/first" -j 1 "${options[@]}" >"$out/first.log" 2>&1
status=$?
set -e
echo "first batch: exit code $status in $(( $(date +%s) - start )) s; $(cat "$out/first/summary.json" | tr -d '\n ')"

# ---- 2. Killed twice, then resumed (a subset) ----------------------------------
rm -rf "$out/resumed" "$out/subset"
mkdir -p "$out/subset"
cp -a "$out/scans/broken" "$out/subset/"
# (read from a process substitution: head closing the pipe early must not
# stop the script under pipefail)
mapfile -t firstScans < <(find "$out/scans" -type l | sort | head -12)
for link in "${firstScans[@]}"; do
  relative=${link#"$out/scans/"}
  mkdir -p "$out/subset/$(dirname "$relative")"
  cp -a "$link" "$out/subset/$relative"
done
for delay in 20 40; do
  timeout -s KILL "$delay" "$apo" batch "$out/subset" -o "$out/resumed" -j 1 "${options[@]}" >>"$out/resumed.log" 2>&1 || true
done
set +e
"$apo" batch "$out/subset" -o "$out/resumed" -j 1 "${options[@]}" >>"$out/resumed.log" 2>&1
echo "resumed batch: exit code $?; $(cat "$out/resumed/summary.json" | tr -d '\n ')"
set -e
python3 - "$out" <<'EOF'
import hashlib, json, pathlib, sys
out = pathlib.Path(sys.argv[1])
same = differ = 0
for manifest in sorted((out / "first").rglob("manifest.json")):
    scan = manifest.parent.relative_to(out / "first")
    if json.loads(manifest.read_text()).get("status") != "succeeded":
        continue
    for name in ("m.ply", "M.ply", "scan.apo", "texture.png"):
        a, b = out / "first" / scan / name, out / "resumed" / scan / name
        if not a.exists() or not (out / "resumed" / scan).exists():
            continue  # not in the subset
        if b.exists() and hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest():
            same += 1
        else:
            differ += 1
            print(f"  DIFFERS: {scan}/{name}")
print(f"killed at 20 s and 40 s, then resumed: {same} output files identical to the uninterrupted batch, {differ} different")
EOF

# ---- 3. The table ----------------------------------------------------------------
python3 - "$out/first" <<'EOF'
import json, pathlib, sys
root = pathlib.Path(sys.argv[1])
stages = ["ingest", "reconstruct", "simplify", "bake", "render", "report"]
print()
print("| scan | input | status | " + " | ".join(f"{s} s (MiB)" for s in stages) + " | total s | APO / m alone (deg) |")
print("|---|---|---|" + "---|" * (len(stages) + 2))
totals = []
for manifest_path in sorted(root.rglob("manifest.json")):
    m = json.loads(manifest_path.read_text())
    scan = manifest_path.parent.relative_to(root)
    ingest = m.get("results", {}).get("ingest", {})
    size = f"{m.get('input', {}).get('bytes', 0) / 2**20:.1f} MiB"
    cells = []
    total = 0.0
    for record in m.get("stages", []):
        if record.get("status") == "succeeded":
            cells.append(f"{record['seconds']:.1f} ({record['peak_memory_bytes'] >> 20})")
            total += record["seconds"]
        else:
            cells.append(record.get("status", "?").replace("_", " "))
    status = m.get("status", "?")
    if status == "failed":
        error = m.get("error") or {}
        message = str(error.get("message", "")).replace("|", "/").replace("\n", " ")
        status = f"failed at {error.get('stage', '?')}: {message[:90]}"
    render = m.get("results", {}).get("render", {}).get("overall", {})
    angles = f"{render['apo']['mean']:.2f} / {render['baseline']['mean']:.2f}" if render else "-"
    print(f"| {scan} | {size} | {status} | " + " | ".join(cells) + f" | {total:.1f} | {angles} |")
EOF

# ---- 4. The summary --------------------------------------------------------------
echo
python3 bench/pipeline_summary.py "$out/first"
