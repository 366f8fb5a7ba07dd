#!/usr/bin/env bash
# Rebuilds the README's pictures of one dam-break frame: the adaptive mesh, the smoothed mesh and
# the levels coloured, each rendered by docs/images/render.py with Blender's Cycles on the CPU.
#
#   bash docs/images/make_images.sh            # from the repository root, after building the CLI
#
# Needs: build/bin/trilevel (or TRILEVEL=...), Blender 3.x (`apt-get install -y blender`, or
# BLENDER=...), the frame in ../shared/data (or FRAME=...), and, to keep each image under 200 KB,
# Python 3 with Pillow (`apt-get install -y python3-pil`) to store the PNGs with a 256-colour palette.
# The smoothed picture is skipped, with a message, when the CLI has no --smooth.
# Environment: SAMPLES (Cycles samples per pixel, 32), WIDTH x HEIGHT (640 x 400), WORK (meshes,
# build/images), OUT (the images, docs/images), THREADS (render and reconstruction threads, 2),
# PICTURES (which to make, "adaptive levels smoothed").
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/../.." && pwd)
TRILEVEL=${TRILEVEL:-$ROOT/build/bin/trilevel}
BLENDER=${BLENDER:-blender}
FRAME=${FRAME:-$ROOT/../shared/data/dam_break_frame_23_24389_particles.bgeo}
RADIUS=${RADIUS:-0.025}
SAMPLES=${SAMPLES:-32}
WIDTH=${WIDTH:-640}
HEIGHT=${HEIGHT:-400}
THREADS=${THREADS:-2}
WORK=${WORK:-$ROOT/build/images}
OUT=${OUT:-$ROOT/docs/images}
# Debian's interpreter first: a python3 earlier on PATH (pyenv's) may lack Pillow.
PICTURES=${PICTURES:-adaptive levels smoothed}
PYTHON=${PYTHON:-$(command -v /usr/bin/python3 || command -v python3 || true)}
# One camera for every picture (mesh coordinates, y up): the pool and the wave on the far wall.
CAMERA=(--target 0.2,1.2,0 --azimuth -30 --elevation 24 --distance 5.0 --lens 35)

die() { echo "make_images.sh: error: $*" >&2; exit 1; }
[ -x "$TRILEVEL" ] || die "no trilevel CLI at $TRILEVEL (build it, or set TRILEVEL)"
command -v "$BLENDER" >/dev/null || die "no Blender ($BLENDER); apt-get install -y blender, or set BLENDER"
[ -f "$FRAME" ] || die "no particle frame at $FRAME (set FRAME)"
mkdir -p "$WORK" "$OUT"

reconstruct() {  # OUT.ply ARGS...
    local out=$1; shift
    echo "+ trilevel reconstruct $(basename "$FRAME") -r $RADIUS $* -o $(basename "$out")"
    "$TRILEVEL" reconstruct "$FRAME" -r "$RADIUS" --threads "$THREADS" -q --stats "${out%.ply}.json" -o "$out" "$@"
}

render() {  # MESH.ply NAME STYLE
    local mesh=$1 name=$2 style=$3 raw="$WORK/$2.png"
    echo "+ render $name ($style, ${WIDTH}x${HEIGHT}, $SAMPLES samples)"
    "$BLENDER" -b --factory-startup --python-exit-code 1 --python "$ROOT/docs/images/render.py" -- "$mesh" "$raw" --style "$style" \
        --width "$WIDTH" --height "$HEIGHT" --samples "$SAMPLES" --threads "$THREADS" "${CAMERA[@]}" \
        > "$WORK/$name.blender.log" 2>&1 || { tail -20 "$WORK/$name.blender.log" >&2; die "Blender failed on $name"; }
    # A 256-colour palette keeps a 640x400 render near 100 KB; without Pillow the RGB PNG is kept.
    if [ -n "$PYTHON" ] && "$PYTHON" -c "import PIL" 2>/dev/null; then
        "$PYTHON" - "$raw" "$OUT/$name.png" <<'EOF'
import os, sys
from PIL import Image
src, dst = sys.argv[1], sys.argv[2]
img = Image.open(src).convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
img.save(dst + ".tmp.png", optimize=True)
os.replace(dst + ".tmp.png", dst)
EOF
    else
        cp "$raw" "$OUT/$name.png"
    fi
    echo "  $OUT/$name.png: $(stat -c %s "$OUT/$name.png") bytes"
}

want() { case " $PICTURES " in *" $1 "*) return 0;; *) return 1;; esac; }

if want adaptive || want levels; then
    reconstruct "$WORK/adaptive.ply" --color-levels
    want adaptive && render "$WORK/adaptive.ply" dam-break-adaptive water
    want levels && render "$WORK/adaptive.ply" dam-break-levels levels
fi
if want smoothed; then
    if "$TRILEVEL" reconstruct --help | grep -q -- '--smooth'; then
        reconstruct "$WORK/smoothed.ply" --smooth
        render "$WORK/smoothed.ply" dam-break-smoothed water
    else
        echo "make_images.sh: $TRILEVEL has no --smooth; dam-break-smoothed.png not rendered" >&2
    fi
fi
