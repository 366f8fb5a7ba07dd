#!/usr/bin/env bash
# Builds the libFuzzer targets and their seed corpora, then runs every target (or the ones named)
# for SECONDS each, all at once, one process per target. Exits non-zero on any finding.
#
#   fuzz/run_fuzz.sh [options] SECONDS [TARGET...]       TARGET: vtk vtu bgeo ply xyz mesh
#     --prebuilt DIR  run the binaries in DIR (fuzz_<target>, corpus-<target>/, <target>.dict: a
#                     copy of build-fuzz/fuzz) instead of building; needs no compiler
#     --out DIR       where the grown corpora, logs and findings go (default: <binary dir>/out);
#                     a second run goes on from the corpora grown by the first
#     --jobs N        at most N targets at a time (default: all)
#     --keep-going    go on after a finding (libFuzzer's -fork=1 with crashes, timeouts and OOMs
#                     ignored), so that one long run collects every distinct finding
#   Environment: CXX (default clang++-14) and BUILD_DIR (default build-fuzz) for the build;
#   FUZZ_NICE (default 0) for the niceness of the fuzzers.
#
# A finding is anything but a clean trilevel::Error: a crash, a sanitizer report, another exception,
# a leak, an input taking over 1 s, an allocation over 2 GB, or the process over 4 GB resident (ASan's
# quarantine and libFuzzer's tables alone take about 0.6 GB after 2 minutes, growing slowly with the
# corpus, hence the looser limit on the total). Each lands in OUT/findings/<target>/;
# reproduce it with `DIR/fuzz_<target> FILE`, minimise with `-minimize_crash=1 -runs=10000 FILE`.
set -euo pipefail

usage() { sed -n '2,/^set /s/^# \{0,1\}//p' "$0" | grep -v '^set '; exit 2; }

prebuilt="" out="" jobs=0 mode=()
while [ $# -gt 0 ]; do
  case "$1" in
    --prebuilt) prebuilt="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    --keep-going) mode=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1); shift ;;
    -h|--help) usage ;;
    --*) echo "run_fuzz.sh: unknown option $1" >&2; usage ;;
    *) break ;;
  esac
done
[ $# -ge 1 ] || usage
seconds="$1"; shift
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "run_fuzz.sh: SECONDS must be a whole number, got '$seconds'" >&2; exit 2; }

if [ -n "$prebuilt" ]; then
  dir="$(cd "$prebuilt" && pwd)"
else
  root="$(cd "$(dirname "$0")/.." && pwd)"
  build="${BUILD_DIR:-$root/build-fuzz}"
  cmake -S "$root" -B "$build" -DTRILEVEL_FUZZ=ON -DCMAKE_CXX_COMPILER="${CXX:-clang++-14}" >/dev/null
  cmake --build "$build" -j"$(nproc)"
  dir="$build/fuzz"
fi
out="${out:-$dir/out}"

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for f in "$dir"/fuzz_*; do [ -x "$f" ] && targets+=("${f##*/fuzz_}"); done
fi
[ ${#targets[@]} -gt 0 ] || { echo "run_fuzz.sh: no fuzz_* binaries in $dir" >&2; exit 2; }
for t in "${targets[@]}"; do
  [ -x "$dir/fuzz_$t" ] || { echo "run_fuzz.sh: no target $dir/fuzz_$t" >&2; exit 2; }
done

# A binary that cannot start (say, an older glibc than the build machine's) is not a finding.
for t in "${targets[@]}"; do
  if ! err=$("$dir/fuzz_$t" -help=1 2>&1 >/dev/null); then
    echo "run_fuzz.sh: $dir/fuzz_$t does not run here: $(echo "$err" | head -1)" >&2; exit 2
  fi
done

mkdir -p "$out/logs"
run_one() {
  local t="$1" dict=()
  mkdir -p "$out/findings/$t" "$out/corpus-$t"
  [ -f "$dir/$t.dict" ] && dict=(-dict="$dir/$t.dict")
  # The first corpus directory receives the new inputs; the seeds stay untouched.
  nice -n "${FUZZ_NICE:-0}" "$dir/fuzz_$t" -max_total_time="$seconds" -timeout=1 -rss_limit_mb=4096 \
    -malloc_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$out/findings/$t/" "${dict[@]}" "${mode[@]}" \
    "$out/corpus-$t" "$dir/corpus-$t" >"$out/logs/$t.log" 2>&1
}

declare -A pid_of
for t in "${targets[@]}"; do
  if [ "$jobs" -gt 0 ]; then
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
  fi
  echo "fuzzing $t for ${seconds}s (log: $out/logs/$t.log)"
  run_one "$t" &
  pid_of[$t]=$!
done

status=0
printf '%-6s %8s %10s %8s %8s  %s\n' target exit execs exec/s cov findings
for t in "${targets[@]}"; do
  rc=0
  wait "${pid_of[$t]}" || rc=$?
  log="$out/logs/$t.log"
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  if [ -z "$execs" ]; then  # fork mode: the last status line, "#N: cov: .. exec/s R .."
    execs=$(sed -n 's/^#\([0-9]*\): cov:.*/\1/p' "$log" | tail -1)
    rate=$(sed -n 's/^#[0-9]*: cov:.* exec\/s \([0-9]*\).*/\1/p' "$log" | tail -1)
  fi
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2 || true)
  found=$(find "$out/findings/$t" -type f | wc -l)
  printf '%-6s %8s %10s %8s %8s  %s\n' "$t" "$rc" "${execs:--}" "${rate:--}" "${cov:--}" "$found"
  if [ "$rc" -ne 0 ] || [ "$found" -gt 0 ]; then
    status=1
    grep -m1 -E 'ERROR: |runtime error|trilevel fuzz:|uncaught|Test unit written' "$log" | sed 's/^/    /' || true
    find "$out/findings/$t" -type f | sed "s|^|    reproduce: $dir/fuzz_$t |"
  fi
done
[ "$status" -eq 0 ] && echo "no findings" || echo "FINDINGS: see $out/findings and $out/logs" >&2
exit "$status"
