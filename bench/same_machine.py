#!/usr/bin/env python3
"""trilevel on every OpenCL device of one machine vs splashsurf on the same machine's CPU.

    python3 bench/same_machine.py --trilevel build/bin/trilevel --data DIR --reps 5 \
        [--splashsurf 'python3 -m pysplashsurf'] [--threads 2,16] [--trilevel-threads] [--out RESULTS_DEVICE.md]

For a machine with a GPU (run_bench.py covers the 2-core CI machine, where PoCL is the only
device). With --trilevel-threads, trilevel runs with `--threads N` instead of every core: adaptive at each
of those thread counts, uniform r at the largest (N limits its host stages and PoCL), so every tool is compared at the same
number of threads. DIR holds the datasets as run_bench.py caches them (db23, its x8 and x64 resamplings,
pool-and-drop); each comes with its particle radius below. Every configuration runs once as a
warm-up (fills the driver's kernel cache), then all run interleaved --reps times. Wall time is
the whole process as a user sees it (file read and write included), peak memory the child's max
RSS (wait4); trilevel's own stage times come from its --stats JSON of the last repetition.
Only the standard library (and run_bench.py's helpers beside it).
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from run_bench import ply_counts, run_timed, splashsurf_cmd  # noqa: E402  (one timing and counting code)

DATASETS = [
    ("db23", "dam_break_frame_23_24389_particles.bgeo", 0.025),
    ("pool-and-drop", "pool-and-drop_r0.025.ply", 0.025),
    ("db23x8", "dam_break_frame_23_24389_particles_resample8.bgeo", 0.0125),
    ("db23x64", "dam_break_frame_23_24389_particles_resample64.bgeo", 0.00625),
]


def devices(trilevel):
    out = subprocess.run([trilevel, "devices"], capture_output=True, text=True).stdout
    found = []
    for line in out.splitlines():
        if line[:1].isdigit() and ":" in line:
            idx, name = line.split(":", 1)
            found.append((int(idx), name.strip()))
    return found


def configs(args, tmp):
    """(label, dataset, command builder) for every tool configuration."""
    out = []
    devs = devices(args.trilevel) if not args.devices else [
        (int(d), f"device {d}") for d in args.devices.split(",")]
    threads = [int(n) for n in args.threads.split(",")]
    counts = threads if args.trilevel_threads else [None]  # None: trilevel on every core
    for name, fname, r in DATASETS:
        src = os.path.join(args.data, fname)
        if not os.path.exists(src):
            continue
        for idx, dname in devs:
            # adaptive at every thread count (the peers' too), uniform r at the largest only (the baseline)
            runs = [(["adaptive"], n) for n in counts] + [(["uniform", "--cell", "1"], max(threads) if counts[0] else None)]
            for mode, n in runs:
                label = f"trilevel {' '.join(mode)} on {dname}" + (f", --threads {n}" if n else "")
                stats = os.path.join(tmp, f"{name}-{idx}-{mode[0]}-{n}.json")
                cmd = [args.trilevel, "reconstruct", src, "-r", str(r), "--mode", *mode, "--device", str(idx),
                       "-o", os.path.join(tmp, "out.ply"), "--stats", stats] + (["--threads", str(n)] if n else [])
                out.append((label, name, cmd, stats))
        if args.splashsurf:
            for n in threads:
                label = f"splashsurf -n {n}"
                cmd = splashsurf_cmd(shlex.split(args.splashsurf), src, r, n, os.path.join(tmp, "out.ply"))
                out.append((label, name, cmd, None))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trilevel", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--splashsurf", default="")
    ap.add_argument("--threads", default="2")
    ap.add_argument("--devices", default="", help="comma-separated device indices (default: all)")
    ap.add_argument("--trilevel-threads", action="store_true",
                    help="run trilevel with --threads N at --threads' counts instead of on every core (host stages and PoCL)")
    ap.add_argument("--out", default="")
    ap.add_argument("--timeout", type=float, default=600, help="seconds per run before it is killed")
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="trilevel-same-machine-")
    runs = configs(args, tmp)
    results = {i: [] for i in range(len(runs))}
    extra = {}
    for rep in range(args.reps + 1):  # repetition 0 is the warm-up
        for i, (label, ds, cmd, stats) in enumerate(runs):
            log = os.path.join(tmp, "stderr.txt")
            wall, rss, code = run_timed(cmd, args.timeout, os.devnull, log)
            if code != 0:
                with open(log, errors="replace") as f:
                    print(f"  failed ({code}): {' '.join(cmd)}: {f.read().strip()[-300:]}", file=sys.stderr)
                continue
            if rep > 0:
                results[i].append((wall, rss))
            extra[i] = (ply_counts(os.path.join(tmp, "out.ply"))[1], json.load(open(stats)) if stats else None)
    lines = ["| dataset | tool | wall min (s) | wall median (s) | peak RSS (MB) | triangles | closed | "
             "trilevel stages (ms) |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for i, (label, ds, cmd, stats) in enumerate(runs):
        if not results[i]:
            lines.append(f"| {ds} | {label} | failed | | | | | |")
            continue
        walls = [w for w, _ in results[i]]
        rss = statistics.median(m for _, m in results[i]) / 1e6
        faces, st = extra[i]
        closed = "" if st is None else ("yes" if st.get("closed") else "NO")
        stages = "" if st is None else ", ".join(f"{k} {v:.0f}" for k, v in st["time_ms"].items())
        lines.append(f"| {ds} | {label} | {min(walls):.3f} | {statistics.median(walls):.3f} | {rss:.0f} | "
                     f"{faces} | {closed} | {stages} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
