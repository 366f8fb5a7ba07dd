#!/bin/bash
# The GPU measurements of bench/RESULTS-gpu.md, as one script for a lent GPU machine (minutes of
# device time): binaries built on the CI machine and carried in $DEV with their libraries and data.
#
#   DEV=.dev OUT=results bash bench/gpu_session.sh
#
# $DEV/bin: trilevel, trilevel_tests, device_frames; $DEV/lib: libOpenCL.so.1, libtbb.so.12,
# libdeflate.so.0; $DEV/x64.bgeo (particles.py resample db23 --factor 64 --radius 0.025 --seed 1);
# $DEV/shared: data/ and tools/ of ../shared. Optional: $DEV/x64_s2.bgeo, $DEV/x64_s3.bgeo (seeds 2
# and 3; made on the machine when absent and RESAMPLE=1). TESTS: a Catch test spec for the last
# step (default: every test). Writes $OUT/log.txt and the JSON of each step.
set -u
DEV=${DEV:-.dev}
DEV=$(cd "$DEV" && pwd)
OUT=${OUT:-/tmp/gpu_out}
mkdir -p "$OUT"
exec > >(tee -a "$OUT/log.txt") 2>&1
export LD_LIBRARY_PATH=$DEV/lib
export TRILEVEL_CACHE_DIR=/tmp/trilevel-cache
T=$DEV/bin/trilevel
W=/tmp/gpu_work
R=${R:-0.00625}       # the radius of x64.bgeo
RESAMPLE=${RESAMPLE:-1}
mkdir -p $W
stamp() { echo "== $(date +%T) $*"; }

stamp setup
mkdir -p $DEV/t  # the tests' working directory: ../../tests is the checkout's
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
nproc
mkdir -p /etc/OpenCL/vendors
ls /etc/OpenCL/vendors
grep -l nvidia /etc/OpenCL/vendors/*.icd >/dev/null 2>&1 || echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd
ls /etc/OpenCL/vendors; cat /etc/OpenCL/vendors/*.icd
$T devices
GPU=${GPU:-$($T devices | awk -F: '/^[0-9]+:/ {i=$1} /type GPU/ {print i; exit}')}
CPU=$($T devices | awk -F: '/^[0-9]+:/ {i=$1} /type CPU/ {print i; exit}')
echo "GPU=$GPU CPU=$CPU"
[ -n "$GPU" ] || { echo "no GPU device"; exit 1; }

# The tests' ../shared, at the path the build recorded (tests skip real frames without it).
[ -e "$DEV/../../shared" ] || ln -s "$DEV/shared" "$DEV/../../shared"

stamp "the x64 frames of seeds 2 and 3: carried, or made in the background"
for s in 2 3; do [ -s $DEV/x64_s$s.bgeo ] && ln -sf $DEV/x64_s$s.bgeo $W/x64_s$s.bgeo; done
[ "$RESAMPLE" = 1 ] && (cd $W && for s in 2 3; do [ -s x64_s$s.bgeo ] || nice -n 19 python3 "$DEV/shared/tools/particles.py" resample \
    "$DEV/shared/data/dam_break_frame_23_24389_particles.bgeo" x64_s$s.bgeo --factor 64 --radius 0.025 --seed $s \
    > resample_$s.log 2>&1 & done; wait) &
RPID=$!

stamp "interop and device tests on the GPU (first run compiles the kernels)"
(cd $DEV/t && TRILEVEL_DEVICE=$GPU timeout 120 $DEV/bin/trilevel_tests "[device_positions]" 2>&1 | tail -3)
(cd $DEV/t && TRILEVEL_DEVICE=$GPU timeout 120 $DEV/bin/trilevel_tests "[device]" 2>&1 | tail -3)
$T reconstruct $DEV/x64.bgeo -r $R -o $W/warm.ply -q --device $CPU --threads 16  # PoCL's compile

stamp "waiting for the resampled frames"
wait $RPID
FILES="$DEV/x64.bgeo"
for s in 2 3; do [ -s $W/x64_s$s.bgeo ] && FILES="$FILES $W/x64_s$s.bgeo" || cat $W/resample_$s.log; done
echo "frames: $FILES"

stamp "in-process frames/s: GPU 16 and 2 host threads, PoCL 16 threads"
$DEV/bin/device_frames --device $GPU --threads 16 --frames ${FRAMES:-12} --radius $R --json $OUT/gpu16.json $FILES
$DEV/bin/device_frames --device $GPU --threads 2 --frames ${FRAMES_SLOW:-6} --radius $R --json $OUT/gpu2.json $FILES
$DEV/bin/device_frames --device $CPU --threads 16 --frames ${FRAMES_SLOW:-6} --radius $R --json $OUT/pocl16.json $FILES

stamp "CLI, whole process: one x64 frame, 3 interleaved pairs"
timed() {  # LABEL CMD...: the whole process's wall time and peak RSS
  python3 -c "import subprocess,sys,time,resource; t=time.perf_counter(); rc=subprocess.run(sys.argv[2:]).returncode; w=time.perf_counter()-t; print('%s: rc %d, wall %.3f s, peak %d MiB' % (sys.argv[1], rc, w, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss // 1024))" "$@"
}
for i in 1 2 3; do
  for d in $GPU $CPU; do
    timed "one frame, device $d" $T reconstruct $DEV/x64.bgeo -r $R -o $W/one_$d.ply -q --device $d --threads 16 --stats $OUT/one_$d.json
  done
done
cmp $W/one_$GPU.ply $W/one_$CPU.ply && echo "GPU and PoCL meshes identical" || echo "GPU and PoCL meshes differ (rounding, docs/design.md)"

stamp "CLI sequence: 12 x64 frames (the files cycled), whole process"
set -- $FILES
for k in $(seq 0 11); do f=$(eval echo \${$(( k % $# + 1 ))}); ln -sf $f $W/in_$k.bgeo; done
for d in $GPU $CPU; do
  timed "sequence of 12, device $d" $T reconstruct "$W/in_{}.bgeo" -r $R -o "$W/seq_${d}_{}.ply" -q --device $d --threads 16
done
echo "(frames/s = 12 / wall)"

stamp "CLI sequence: the pipeline's finisher (frame k's triangulation beside frame k+1's device stages) off and on (12 frames, GPU)"
for f in 0 1 0 1; do
  TRILEVEL_PIPELINE_FINISHER=$f timed "sequence of 12, finisher $f" $T reconstruct "$W/in_{}.bgeo" -r $R \
    -o "$W/plain_${f}_{}.ply" -q --device $GPU --threads 16
done
for k in $(seq 0 11); do cmp -s $W/plain_0_$k.ply $W/plain_1_$k.ply || echo "frame $k differs"; done

stamp "CLI sequence with --smooth: the pipeline's finisher thread off and on (12 frames, GPU)"
for f in 0 1 0 1; do
  TRILEVEL_PIPELINE_FINISHER=$f timed "smoothed sequence of 12, finisher $f" $T reconstruct "$W/in_{}.bgeo" -r $R \
    -o "$W/smooth_${f}_{}.ply" -q --device $GPU --threads 16 --smooth
done
for k in $(seq 0 11); do cmp -s $W/smooth_0_$k.ply $W/smooth_1_$k.ply || echo "smoothed frame $k differs"; done

if [ -x $DEV/bin/trilevel_probe ]; then  # a build with timing prints in the triangulation, where carried
  stamp "triangulation's parts on the GPU, 16 threads"
  for i in 1 2; do $DEV/bin/trilevel_probe reconstruct $DEV/x64.bgeo -r $R -o $W/probe.ply -q --device $GPU --threads 16; done
fi

stamp "tests on the GPU: ${TESTS:-all}"
# The CLI tests start the CLI where the build put it: the checkout's build/bin.
mkdir -p "$DEV/../build/bin" && { [ -e "$DEV/../build/bin/trilevel" ] || cp $T "$DEV/../build/bin/trilevel"; }
(cd $DEV/t && TRILEVEL_DEVICE=$GPU timeout ${TESTS_TIMEOUT:-200} $DEV/bin/trilevel_tests -# ${TESTS:-} > $OUT/tests.txt 2>&1; tail -4 $OUT/tests.txt)
stamp done
