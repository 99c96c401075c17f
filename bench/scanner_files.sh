#!/usr/bin/env bash
# Issue 44: every real E57 and LAZ file (../shared/data/e57, ../shared/data/laz)
# through `apo ingest --no-normals` (the reader and cleaning: some files hold
# too few distinct points for normals), with what an independent reader says of it
# (docs/benchmarks.md, "Scanner files").
# Columns: exit code, points read, scans (scan positions; 1 for LAZ),
# seconds reading, peak MiB of the whole ingest (/usr/bin/time), and the
# agreement:
# - LAZ: our decompressed records (build/laz_speed) against laz-perf's
#   (npm, LAZperf's C++ in WASM: tests/ingest/lazperf_decode.mjs) by SHA-256;
# - E57: the records each scan declares (bench/e57_declared.py parses the
#   XML section itself) against points read plus invalid ones skipped (the
#   reader's notes).
# Usage (after the README's setup and build, with
#   cmake --build build --target laz_speed):
#   bash bench/scanner_files.sh [OUTDIR]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench/scanner_files}
data=${DATA:-../shared/data}
mkdir -p "$out"
apo=${APO_BIN:-build/apo}
echo "date: $(date -u +%Y-%m-%dT%H:%MZ), commit $(git describe --always --dirty), load: $(uptime | sed 's/.*average: //')"
echo
printf '| file | exit | points read | scans | read s | peak MiB | independent reader |\n|---|---|---|---|---|---|---|\n'
for file in "$data"/e57/*.e57 "$data"/laz/*.laz; do
  name=$(basename "$file")
  dir="$out/${name%.*}"
  rm -rf "$dir"
  status=0
  /usr/bin/time -f '%M' -o "$out/time.txt" "$apo" -q ingest --no-normals "$file" -o "$dir" 2>"$out/stderr.txt" >/dev/null || status=$?
  peak=$(( $(tail -n 1 "$out/time.txt") / 1024 ))
  if [ "$status" -eq 0 ]; then
    read -r points scans seconds skipped < <(python3 - "$dir/ingest.json" <<'PY'
import json, re, sys
j = json.load(open(sys.argv[1]))
skipped = sum(int(m.group(1)) for n in j['read_notes'] for m in [re.search(r'(\d+) of \d+ records skipped as invalid', n)] if m)
print(j['counts']['points_in'], max(1, len(j['scan_positions'])), '%.3f' % j['seconds']['read'], skipped)
PY
)
  else
    points="refused: $(head -c 160 "$out/stderr.txt" | tr '\n|' '  ' | sed "s|$data/||")" scans=- seconds=- skipped=0
  fi
  case "$name" in
    *.laz)
      theirs=$(node tests/ingest/lazperf_decode.mjs "$file" 2>/dev/null || true)
      ours=$(build/laz_speed "$file" 1 2>/dev/null || true)
      agreement=$(python3 -c '
import json, sys
def load(t):
    try: return json.loads(t)
    except Exception: return {"error": "no output"}
a, b = load(sys.argv[1]), load(sys.argv[2])
if "error" in b: print("laz-perf refuses it too" if "error" in a else "laz-perf refuses: " + b["error"][:60])
elif "error" in a: print("laz-perf reads %d points; apo refuses" % b["points"])
elif a["sha256"] == b["sha256"]: print("same %d records as laz-perf" % b["points"])
else: print("DIFFERS from laz-perf")' "$ours" "$theirs")
      ;;
    *.e57)
      agreement=$(python3 -c '
import json, sys
d = json.loads(sys.argv[1]); read = sys.argv[2]; skipped = int(sys.argv[3])
if "error" in d: print("XML unreadable: " + d["error"][:60])
elif not read.isdigit(): print("declares %s records" % sum(d["scans"]))
elif int(read) + skipped == sum(d["scans"]): print("%d declared = %d read + %d invalid" % (sum(d["scans"]), int(read), skipped))
else: print("DIFFERS: %d declared, %d read + %d invalid" % (sum(d["scans"]), int(read), skipped))' \
        "$(python3 bench/e57_declared.py "$file")" "${points%% *}" "$skipped")
      ;;
  esac
  printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$name" "$status" "$points" "$scans" "$seconds" "$peak" "$agreement"
done
