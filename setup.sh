#!/usr/bin/env bash
# Installs every Debian package the project needs to build, test and fetch its
# datasets (as root, on Debian 12; nothing when all are present), and the npm
# packages of package-lock.json (npm ci; nothing when already installed).
set -euo pipefail

# The one list of the project's system dependencies.
PACKAGES=(
  # toolchain
  build-essential cmake pkg-config git ca-certificates
  # geometry and scan processing
  libpcl-dev libflann-dev libnanoflann-dev libcgal-dev libembree-dev libglm-dev libopen3d-dev
  libeigen3-dev libtbb-dev libboost-dev libmeshoptimizer-dev libdraco-dev
  # headless rendering
  libosmesa6-dev
  # command line, formats, logging, hashing
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libstb-dev libssl-dev libdeflate-dev liblzf-dev
  # E57's XML section (ingest/e57_reader.cpp)
  libpugixml-dev
  # tests and benchmarks; headless Chromium and its WebDriver for the QA
  # report's browser test (tests/report/browser_check.py); clang and its
  # runtime (libFuzzer, ASan, UBSan) for the fuzzers (fuzz/run.sh)
  libgtest-dev libgmock-dev libbenchmark-dev chromium chromium-driver clang libclang-rt-14-dev
  # the independent measuring scripts of ../shared/tools/ (benchmarks only)
  python3-numpy python3-scipy python3-open3d python3-pil
  # an independent CRC-32C for the E57 writer's pages (tests/ingest/e57_reader_test.cpp)
  python3-crc32c
  # the cluster test (tests/cluster/slurm_check.sh): a one-node Slurm
  # cluster and its authentication; dpkg-dev's dpkg-shlibdeps for CPack's .deb
  slurm-wlm munge dpkg-dev
  # dataset scripts (bunzip2 for the octomap scan)
  bzip2 xz-utils
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done

install_packages() {
  if [ ${#missing[@]} -eq 0 ]; then
    echo "setup: all ${#PACKAGES[@]} packages present"
    return
  fi
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: missing packages (${missing[*]}); run this script as root" >&2
    exit 1
  fi
  echo "setup: installing ${#missing[@]} packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
}
install_packages

# The independent JavaScript readers the tests check apo against, pinned by
# package-lock.json, with the machine's Node.js and npm; the tests then run
# offline. Skipped when node_modules was installed from this lockfile.
cd "$(dirname "$0")"
if [ ! -f node_modules/.package-lock.json ] || [ package-lock.json -nt node_modules/.package-lock.json ]; then
  echo "setup: npm ci (package-lock.json)"
  npm ci --no-audit --no-fund
fi
