#!/usr/bin/env python3
"""What a page of fresh memory costs on this machine, and what it costs a bake.

On the virtual machines this project is measured on, the first touch of
memory the host has not backed yet costs far more than the kernel's zeroing
of a page: the host faults it in. Memory a process frees goes back to the
guest kernel, which hands it back to the host after a few seconds (free page
reporting), so a program run right after another reuses pages the host
already backs, and one run after a pause does not. This measures both:

  1. one GiB of anonymous memory touched page by page, with 4 KiB pages and
     with transparent huge pages (madvise), after a pause and right after
     the same touch by the same process (seconds per GiB);
  2. with --bake APO DETAIL COARSE: one `apo bake` after a pause and one
     right after it, wall, user and system seconds (/usr/bin/time).

Usage:
  python3 bench/fresh_memory.py [--pause 8] [--repeats 3]
      [--bake build/apo out/speed/inputs/bunny_1M.ply out/speed/inputs/bunny_m/m.ply]
(the bunny inputs are made by bench/build_speed.sh).
"""
import argparse
import mmap
import statistics
import subprocess
import tempfile
import time

GIB = 1 << 30
PAGE = 4096


def fresh_gib(huge: bool) -> mmap.mmap:
    region = mmap.mmap(-1, GIB, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    if huge:
        region.madvise(mmap.MADV_HUGEPAGE)
    return region


def seconds_to_write(region: mmap.mmap, value: int) -> float:
    """Seconds to write `value` in one byte of every 4 KiB page."""
    start = time.perf_counter()
    for offset in range(0, GIB, PAGE):
        region[offset] = value
    return time.perf_counter() - start


def touch_seconds(huge: bool) -> float:
    """The first write to every page of a fresh GiB."""
    region = fresh_gib(huge)
    seconds = seconds_to_write(region, 1)
    region.close()
    return seconds


def loop_overhead() -> float:
    """The Python loop alone, over memory already touched (subtracted)."""
    region = fresh_gib(False)
    seconds_to_write(region, 1)
    seconds = seconds_to_write(region, 2)
    region.close()
    return seconds


def bake_times(apo: str, detail: str, coarse: str) -> tuple[float, float, float]:
    with tempfile.TemporaryDirectory() as out, tempfile.NamedTemporaryFile("r") as timing:
        subprocess.run(["/usr/bin/time", "-f", "%e %U %S", "-o", timing.name, apo, "-q", "bake", "--detail", detail,
                        "--coarse", coarse, "-o", out], check=True)
        wall, user, system = (float(x) for x in open(timing.name).read().split())
    return wall, user, system


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pause", type=float, default=8.0, help="seconds idle before a 'fresh' run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--bake", nargs=3, metavar=("APO", "DETAIL", "COARSE"))
    args = parser.parse_args()

    overhead = loop_overhead()
    print(f"Python loop alone: {overhead:.3f} s per GiB (subtracted below)")
    print("| pages | after a pause, s/GiB | right after, s/GiB |")
    print("|---|---|---|")
    for huge in (False, True):
        fresh, again = [], []
        for _ in range(args.repeats):
            time.sleep(args.pause)
            fresh.append(touch_seconds(huge) - overhead)
            again.append(touch_seconds(huge) - overhead)
        label = "2 MiB (THP, madvise)" if huge else "4 KiB"
        print(f"| {label} | {', '.join(f'{s:.3f}' for s in fresh)} | {', '.join(f'{s:.3f}' for s in again)} |")

    if args.bake:
        print()
        print("| apo bake | wall s | user s | system s |")
        print("|---|---|---|---|")
        rows = {"after a pause": [], "right after": []}
        for _ in range(args.repeats):
            time.sleep(args.pause)
            rows["after a pause"].append(bake_times(*args.bake))
            rows["right after"].append(bake_times(*args.bake))
        for label, runs in rows.items():
            for run in runs:
                print(f"| {label} | {run[0]:.2f} | {run[1]:.2f} | {run[2]:.2f} |")
            print(f"| {label}, median | " + " | ".join(f"{statistics.median(c):.2f}" for c in zip(*runs)) + " |")


if __name__ == "__main__":
    main()
