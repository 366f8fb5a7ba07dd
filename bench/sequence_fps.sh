#!/bin/bash
# Frames per second of a frame sequence, one trilevel binary against others (issue 25's sequence
# target: 50 frames of the dam-break frame resampled x8, against the one-frame-at-a-time CLI of
# 60ebeb5). Whole processes, interleaved (one warm-up each, then NEW B [C] NEW B [C] ...), the
# medians of the run-by-run wall-time ratios, and every mesh of NEW compared byte for byte with B's.
#
#   bench/sequence_fps.sh NEW B [C]       e.g. build/bin/trilevel ../base/build/bin/trilevel
#   RUNS=5 FRAMES=50 FACTOR=8 THREADS=2   (the defaults)
#
# The frames: ../shared's frame 23 resampled with particles.py at seeds 1-10, frame k from seed
# (k mod 10) + 1, cached in $TRILEVEL_BENCH_CACHE (default ~/.cache/trilevel-bench). Needs ../shared
# beside the checkout and /usr/bin/python3 with numpy (Debian).
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 NEW B [C]" >&2; exit 2; }
RUNS=${RUNS:-5} FRAMES=${FRAMES:-50} FACTOR=${FACTOR:-8} THREADS=${THREADS:-2}
here=$(cd "$(dirname "$0")/.." && pwd)
shared="$here/../shared"
[ -f "$shared/tools/particles.py" ] || { echo "$0: ../shared is not beside the checkout" >&2; exit 2; }
cache=${TRILEVEL_BENCH_CACHE:-$HOME/.cache/trilevel-bench}/seq_x$FACTOR
mkdir -p "$cache/out"
radius=$(/usr/bin/python3 -c "print(0.025 / round($FACTOR ** (1 / 3)))")  # r of the resampled frame
for seed in $(seq 1 10); do
    [ -f "$cache/s$seed.bgeo" ] || /usr/bin/python3 "$shared/tools/particles.py" resample \
        "$shared/data/dam_break_frame_23_24389_particles.bgeo" "$cache/s$seed.bgeo" \
        --factor "$FACTOR" --radius 0.025 --seed "$seed" >/dev/null
done
last=$((FRAMES - 1))
for k in $(seq 0 $last); do ln -sfn "s$((k % 10 + 1)).bgeo" "$cache/$(printf 'in_%02d' "$k").bgeo"; done

names=(NEW B C)
bins=("$@")
log="$cache/out/times.txt"
: > "$log"
run() {  # name binary [timed]
    local cmd=("$2" reconstruct "$cache/in_{}.bgeo" -r "$radius" -o "$cache/out/$1_{}.ply" -q --threads "$THREADS"
               --start 0 --end "$last")
    if [ -n "${3:-}" ]; then /usr/bin/time -a -o "$log" -f "$1 %e %M %U %S" "${cmd[@]}"; else "${cmd[@]}"; fi
}
for i in "${!bins[@]}"; do run "${names[$i]}" "${bins[$i]}"; done  # warm-up: program caches, page cache
for r in $(seq 1 "$RUNS"); do
    for i in "${!bins[@]}"; do run "${names[$i]}" "${bins[$i]}" timed; done
done
differ=0
for k in $(seq 0 $last); do
    f=$(printf '%02d' "$k")
    cmp -s "$cache/out/NEW_$f.ply" "$cache/out/B_$f.ply" || differ=$((differ + 1))
done
/usr/bin/python3 - "$log" "$FRAMES" "$differ" "$@" <<'PY'
import statistics, sys
log, frames, differ, bins = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
runs = {}
for line in open(log):
    name, wall, kib, user, sys_ = line.split()
    runs.setdefault(name, []).append((float(wall), int(kib) / 1024, float(user) + float(sys_)))
for name, binary in zip(("NEW", "B", "C"), bins):
    r = runs[name]
    print(f"{name} {binary}: wall {statistics.median(x[0] for x in r):.2f} s (median of {len(r)}), "
          f"{frames / statistics.median(x[0] for x in r):.2f} frames/s, CPU {statistics.median(x[2] for x in r):.2f} s, "
          f"peak {max(x[1] for x in r):.0f} MiB")
for other in [n for n in ("B", "C") if n in runs]:
    ratios = [a[0] / b[0] for a, b in zip(runs["NEW"], runs[other])]
    m = statistics.median(ratios)
    print(f"NEW/{other} wall: {m:.3f} ({min(ratios):.3f}-{max(ratios):.3f}), {1 / m:.2f}x the frames per second")
print(f"meshes of NEW and B: {frames - differ} of {frames} byte-identical")
PY
