#!/usr/bin/env bash
# fetch_datasets.sh - obtain real 3D-scan test data from Debian packages.
#
# The packages are only downloaded (apt-get download) and unpacked into a
# temporary directory (dpkg -x); nothing is installed. Selected files land in
# <repo>/datasets/ (git-ignored) and are verified against datasets.sha256,
# which sits beside this script. See README.md beside this script.
#
# Usage: bash datasets_scripts/fetch_datasets.sh [--update-manifest]
#   --update-manifest  rewrite datasets.sha256 from what the packages hold now
#                      (only after checking a changed package by hand).
set -euo pipefail

readonly PROG="datasets"
SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)"
readonly SCRIPT_DIR
DATA_DIR="$(cd "$SCRIPT_DIR/.." && pwd -P)/datasets"
readonly DATA_DIR
readonly MANIFEST="$SCRIPT_DIR/datasets.sha256"
readonly TSV="$DATA_DIR/MANIFEST.tsv"
readonly LOCK="$DATA_DIR/.fetch.lock"
readonly LOCK_WAIT_SECONDS=1800

# --- what we take from each package ------------------------------------------
readonly PKG_CGAL="libcgal-demo"
readonly CGAL_TARBALL="usr/share/doc/libcgal-dev/data.tar.gz"
readonly CGAL_DIRS=(points_3 meshes)          # data/<dir>/* -> cgal/<dir>/*

readonly PKG_PCL="python3-pcl"
readonly PCL_DOC="usr/share/doc/python3-pcl"
readonly PCL_FILES=(                            # found under $PCL_DOC/examples
  table_scene_lms400.pcd
  table_scene_mug_stereo_textured.pcd
  bun0.pcd
  milk.pcd
  milk_cartoon_all_small_clorox.pcd
  lamppost.pcd
)

readonly PKG_OCTOMAP="liboctomap-dev"
readonly OCTOMAP_DOC="usr/share/doc/liboctomap-dev"
readonly OCTOMAP_FILES=(scan.dat.bz2 geb079.bt spherical_scan.graph)

readonly PACKAGES=("$PKG_CGAL" "$PKG_PCL" "$PKG_OCTOMAP")

# --- helpers ------------------------------------------------------------------
log() { printf '%s: %s\n' "$PROG" "$*" >&2; }
die() { printf '%s: ERROR: %s\n' "$PROG" "$*" >&2; exit 1; }

usage() {
  sed -n '2,11p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
}

update_manifest=0
for arg in "$@"; do
  case "$arg" in
    --update-manifest) update_manifest=1 ;;
    -h|--help) usage; exit 0 ;;
    *) usage >&2; die "unknown argument: $arg" ;;
  esac
done

for tool in apt-get dpkg dpkg-deb tar gzip sha256sum flock find stat; do
  command -v "$tool" >/dev/null 2>&1 || die "required tool '$tool' not found"
done

# Relative paths listed in the manifest (one per line), after checking syntax.
# Lines are "<64 hex>  <path>"; mawk (Debian's default awk) has no {64}.
manifest_paths() {
  awk '
    /^#/ || /^[[:space:]]*$/ { next }
    substr($0, 1, 64) ~ /^[0-9a-f]+$/ && substr($0, 65, 2) == "  " &&
      substr($0, 67) ~ /^[^[:space:]]/ { print substr($0, 67); next }
    { if (++bad <= 3) printf "malformed line %d: %s\n", NR, $0 > "/dev/stderr" }
    END { exit bad > 0 }' "$MANIFEST"
}

# Version of PKG recorded in the manifest header ("# package PKG VERSION").
manifest_version() {
  awk -v p="$1" '$1 == "#" && $2 == "package" && $3 == p { print $4; exit }' \
    "$MANIFEST" 2>/dev/null || true
}

# True when every manifest file is in datasets/ with the right checksum and
# MANIFEST.tsv lists exactly those files. Touches neither apt nor the network.
all_present() {
  [[ -s "$MANIFEST" && -f "$TSV" ]] || return 1
  local want have
  want="$(manifest_paths 2>/dev/null | LC_ALL=C sort)" || return 1
  [[ -n "$want" ]] || return 1
  have="$(tail -n +2 "$TSV" | cut -f1 | LC_ALL=C sort)"
  [[ "$want" == "$have" ]] || return 1
  (cd "$DATA_DIR" && sha256sum --quiet --strict -c "$MANIFEST") >/dev/null 2>&1
}

count_files() { manifest_paths | wc -l | tr -d ' '; }

report_present() {
  printf '%s: all %s files present and verified\n' "$PROG" "$(count_files)"
}

# --- fast path: nothing to do ---------------------------------------------------
if [[ $update_manifest -eq 0 && ! -s "$MANIFEST" ]]; then
  die "manifest $MANIFEST is missing or empty; create it with: bash $0 --update-manifest"
fi
if [[ $update_manifest -eq 0 ]]; then
  manifest_paths >/dev/null || die "malformed manifest $MANIFEST"
  if all_present; then
    # Drop work dirs left by a killed run, unless a run is active right now.
    if compgen -G "$DATA_DIR/.tmp-fetch.*" >/dev/null && exec 9>>"$LOCK" && flock -n 9; then
      rm -rf "$DATA_DIR"/.tmp-fetch.*
    fi
    report_present
    exit 0
  fi
fi

# --- slow path: fetch under an exclusive lock ------------------------------------
mkdir -p "$DATA_DIR"
exec 9>>"$LOCK"
if ! flock -n 9; then
  log "another fetch is running; waiting for it (up to ${LOCK_WAIT_SECONDS}s)"
  flock -w "$LOCK_WAIT_SECONDS" 9 || die "timed out waiting for lock $LOCK"
fi
# The other run may have done the work while we waited.
if [[ $update_manifest -eq 0 ]] && all_present; then
  report_present
  exit 0
fi

# We hold the lock, so any leftover work dir is from an interrupted run.
rm -rf "$DATA_DIR"/.tmp-fetch.*
# The work dir lives inside datasets/ so the final mv is an atomic rename.
WORK="$(mktemp -d "$DATA_DIR/.tmp-fetch.XXXXXX")"
cleanup() { rm -rf "$WORK"; }
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

readonly DEBS="$WORK/debs" UNPACK="$WORK/unpack" STAGE="$WORK/stage"
readonly ORIGIN="$WORK/origin.tsv"   # path \t package \t version
mkdir -p "$DEBS" "$UNPACK" "$STAGE"
: >"$ORIGIN"

start_seconds=$SECONDS

# bunzip2 is in Debian's "bzip2" package (priority standard, not always
# present). If missing, borrow the binary from a downloaded bzip2 .deb; its
# only library, libbz2-1.0, is always installed because dpkg needs it.
download_pkgs=("${PACKAGES[@]}")
BUNZIP2=(bunzip2)
if ! command -v bunzip2 >/dev/null 2>&1; then
  log "bunzip2 not found; will use the binary from the bzip2 package"
  download_pkgs+=(bzip2)
  BUNZIP2=()
fi

apt_download() {
  # APT::Sandbox::User=root: the _apt user cannot write into our root-owned
  # work dir; this avoids apt's "unsandboxed download" warning.
  (cd "$DEBS" && rm -f ./*.deb &&
    apt-get -q -o APT::Sandbox::User=root download "$@") >"$WORK/download.log" 2>&1
}

log "downloading ${download_pkgs[*]} (apt-get download, nothing is installed)"
if ! apt_download "${download_pkgs[@]}"; then
  # Missing package lists (fresh machine) or stale ones (package superseded).
  log "apt-get download failed (no or outdated package lists?): $(grep -E '^(E|W):' "$WORK/download.log" | head -n 3 | tr '\n' ' ')"
  [[ "$(id -u)" -eq 0 ]] || die "apt-get update needs root; run as root or run 'apt-get update' first"
  log "running apt-get update"
  apt-get -q update >"$WORK/update.log" 2>&1 ||
    die "apt-get update failed: $(tail -n 5 "$WORK/update.log" | tr '\n' ' ')"
  apt_download "${download_pkgs[@]}" ||
    die "apt-get download ${download_pkgs[*]} failed after apt-get update: $(tail -n 5 "$WORK/download.log" | tr '\n' ' ')"
fi

declare -A VERSION
for pkg in "${download_pkgs[@]}"; do
  debs=("$DEBS/${pkg}_"*.deb)
  [[ ${#debs[@]} -eq 1 && -f "${debs[0]}" ]] || die "expected one downloaded .deb for $pkg, found: ${debs[*]}"
  [[ "$(dpkg-deb -f "${debs[0]}" Package)" == "$pkg" ]] || die "${debs[0]} is not package $pkg"
  VERSION[$pkg]="$(dpkg-deb -f "${debs[0]}" Version)"
  log "  $pkg ${VERSION[$pkg]} ($(stat -c %s "${debs[0]}") bytes)"
  mkdir -p "$UNPACK/$pkg"
  dpkg -x "${debs[0]}" "$UNPACK/$pkg" || die "dpkg -x failed for ${debs[0]}"
done

if [[ ${#BUNZIP2[@]} -eq 0 ]]; then
  bz="$(find "$UNPACK/bzip2" -type f -name bzip2 -perm -u+x | head -n 1)"
  [[ -n "$bz" ]] || die "no bzip2 binary found in the bzip2 package"
  BUNZIP2=("$bz" -d)
fi

# stage SRC REL PKG: move SRC to $STAGE/REL and note where it came from.
stage() {
  local src="$1" rel="$2" pkg="$3"
  [[ -f "$src" ]] || die "$pkg ${VERSION[$pkg]}: expected file missing: ${src#"$UNPACK/"}"
  [[ ! -e "$STAGE/$rel" ]] || die "two sources for $rel"
  mkdir -p "$(dirname "$STAGE/$rel")"
  mv "$src" "$STAGE/$rel"
  printf '%s\t%s\t%s\n' "$rel" "$pkg" "${VERSION[$pkg]}" >>"$ORIGIN"
}

# 1. CGAL: data.tar.gz inside libcgal-demo.
log "extracting CGAL data (${CGAL_DIRS[*]}) from $CGAL_TARBALL"
tarball="$UNPACK/$PKG_CGAL/$CGAL_TARBALL"
[[ -f "$tarball" ]] || die "$PKG_CGAL ${VERSION[$PKG_CGAL]}: $CGAL_TARBALL not found (package layout changed?)"
mkdir -p "$WORK/cgal"
members=()
for d in "${CGAL_DIRS[@]}"; do members+=("data/$d"); done
tar -xzf "$tarball" -C "$WORK/cgal" --no-same-owner "${members[@]}" ||
  die "could not extract ${members[*]} from $CGAL_TARBALL"
while IFS= read -r -d '' f; do
  stage "$f" "cgal/${f#"$WORK/cgal/data/"}" "$PKG_CGAL"
done < <(find "$WORK/cgal/data" -type f -print0 | LC_ALL=C sort -z)

# 2. PCL tutorial data inside python3-pcl's examples.
log "extracting PCL data from $PKG_PCL"
for name in "${PCL_FILES[@]}"; do
  mapfile -t hits < <(find "$UNPACK/$PKG_PCL/$PCL_DOC/examples" -type f -name "$name")
  [[ ${#hits[@]} -eq 1 ]] || die "$PKG_PCL ${VERSION[$PKG_PCL]}: expected one $name, found ${#hits[@]}"
  stage "${hits[0]}" "pcl/$name" "$PKG_PCL"
done
stage "$UNPACK/$PKG_PCL/$PCL_DOC/copyright" "pcl/copyright" "$PKG_PCL"

# 3. OctoMap example data inside liboctomap-dev.
log "extracting OctoMap example data from $PKG_OCTOMAP"
for name in "${OCTOMAP_FILES[@]}"; do
  stage "$UNPACK/$PKG_OCTOMAP/$OCTOMAP_DOC/examples/data/$name" "octomap/$name" "$PKG_OCTOMAP"
done
stage "$UNPACK/$PKG_OCTOMAP/$OCTOMAP_DOC/copyright" "octomap/copyright" "$PKG_OCTOMAP"
"${BUNZIP2[@]}" -k -c "$STAGE/octomap/scan.dat.bz2" >"$WORK/scan.dat" ||
  die "bunzip2 of scan.dat.bz2 failed"
# The same points under the extension `apo` reads as whitespace columns: the
# file holds only "x y z" lines (no NODE lines), sensor at the origin.
cp "$WORK/scan.dat" "$WORK/scan.xyz"
stage "$WORK/scan.dat" "octomap/scan.dat" "$PKG_OCTOMAP"
stage "$WORK/scan.xyz" "octomap/scan.xyz" "$PKG_OCTOMAP"

# --- manifest ----------------------------------------------------------------------
if [[ $update_manifest -eq 1 ]]; then
  tmp_manifest="$MANIFEST.tmp.$$"
  {
    echo "# sha256 of every file fetch_datasets.sh lands in datasets/ (paths relative to it)."
    echo "# Check by hand: cd datasets && sha256sum -c ../datasets_scripts/datasets.sha256"
    echo "# Written by fetch_datasets.sh --update-manifest from these Debian packages:"
    for pkg in "${PACKAGES[@]}"; do echo "# package $pkg ${VERSION[$pkg]}"; done
    (cd "$STAGE" && cut -f1 "$ORIGIN" | LC_ALL=C sort | tr '\n' '\0' | xargs -0 sha256sum --)
  } >"$tmp_manifest"
  mv -f "$tmp_manifest" "$MANIFEST"
  log "wrote $MANIFEST ($(count_files) files)"
fi

# --- verify everything before installing anything ----------------------------------
declare -A FROM
while IFS=$'\t' read -r rel pkg ver; do FROM[$rel]="$pkg $ver"; done <"$ORIGIN"

manifest_paths >/dev/null || die "malformed manifest $MANIFEST"
mapfile -t wanted < <(manifest_paths)
[[ ${#wanted[@]} -gt 0 ]] || die "manifest $MANIFEST lists no files"

check_out="$( (cd "$STAGE" && sha256sum --quiet --strict -c "$MANIFEST") 2>&1)" && check_rc=0 || check_rc=$?
if [[ $check_rc -ne 0 ]]; then
  errors=0
  for rel in "${wanted[@]}"; do
    if [[ ! -f "$STAGE/$rel" ]]; then
      printf '%s: ERROR: %s is listed in the manifest but no longer found in the packages\n' "$PROG" "$rel" >&2
      errors=$((errors + 1))
    elif grep -qxF "$rel: FAILED" <<<"$check_out"; then
      printf '%s: ERROR: checksum mismatch for %s (from %s)\n' "$PROG" "$rel" "${FROM[$rel]:-?}" >&2
      errors=$((errors + 1))
    fi
  done
  [[ $errors -gt 0 ]] || printf '%s\n' "$check_out" >&2
  for pkg in "${PACKAGES[@]}"; do
    old="$(manifest_version "$pkg")"
    if [[ -n "$old" && "$old" != "${VERSION[$pkg]}" ]]; then
      log "note: manifest was made from $pkg $old, apt fetched ${VERSION[$pkg]}"
    fi
  done
  die "verification failed for ${errors} file(s); nothing was changed in $DATA_DIR.
  The Debian package(s) may have been updated and their data changed.
  Inspect the new files; if they are acceptable, regenerate the manifest with:
    bash $SCRIPT_DIR/fetch_datasets.sh --update-manifest"
fi

extra="$(comm -13 <(printf '%s\n' "${wanted[@]}" | LC_ALL=C sort) <(cut -f1 "$ORIGIN" | LC_ALL=C sort) | wc -l)"
[[ "$extra" -eq 0 ]] || log "note: $extra file(s) found in the packages but not in the manifest were skipped"

# --- install: atomic rename of each verified file into datasets/ ------------------
for rel in "${wanted[@]}"; do
  mkdir -p "$(dirname "$DATA_DIR/$rel")"
  chmod 0644 "$STAGE/$rel"
  mv -f "$STAGE/$rel" "$DATA_DIR/$rel"
done

tmp_tsv="$TSV.tmp.$$"
{
  printf 'path\tsize_bytes\tsha256\tpackage\tversion\n'
  while read -r sum rel; do
    [[ "$sum" == \#* || -z "$sum" ]] && continue
    read -r pkg ver <<<"${FROM[$rel]}"
    printf '%s\t%s\t%s\t%s\t%s\n' "$rel" "$(stat -c %s "$DATA_DIR/$rel")" "$sum" "$pkg" "$ver"
  done <"$MANIFEST"
} >"$tmp_tsv"
mv -f "$tmp_tsv" "$TSV"

total_bytes="$(tail -n +2 "$TSV" | awk -F'\t' '{s += $2} END {print s + 0}')"
log "installed ${#wanted[@]} files ($total_bytes bytes) into $DATA_DIR in $((SECONDS - start_seconds))s"
for pkg in "${PACKAGES[@]}"; do log "  $pkg ${VERSION[$pkg]}"; done
report_present
