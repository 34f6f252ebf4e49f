#!/usr/bin/env bash
# fabrica-viewer orbit benchmark (issue 18): 120 frames at 1280x800 turning
# once around the bundled igea (c3d_igea.ply, 134k vertices) with contours,
# suggestive contours and apparent ridges recomputed for every frame; prints
# the median and 95th percentile of the frame time (and of the lines' time)
# from the viewer's frame log. Not a timed test: record the figures in
# docs/PERFORMANCE.md with the CPU model.
#
#   bench/viewer_orbit.sh [BUILD_DIR] [FRAMES] [hybrid]
#
# `hybrid` draws the apparent ridges by the hybrid GPU method instead.
# Without a display the viewer runs under xvfb-run.
set -euo pipefail
build="${1:-build}" frames="${2:-120}" mode="${3:-object}"
if ! [[ "$frames" =~ ^[1-9][0-9]*$ ]]; then
  echo "viewer_orbit: FRAMES must be a positive integer (got '$frames')" >&2
  exit 2
fi
viewer="$build/apps/viewer/fabrica-viewer"
mesh="$build/test-data/data/meshes/classic/c3d_igea.ply"
for f in "$viewer" "$mesh"; do
  if [ ! -e "$f" ]; then
    echo "viewer_orbit: $f is missing; build fabrica-viewer in $build first" >&2
    exit 2
  fi
done
hybrid=false
[ "$mode" = hybrid ] && hybrid=true
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cat >"$work/orbit.txt" <<SCRIPT
open "$mesh"
wait
set c3d_igea lines=contour,suggestive,apparent hybrid=$hybrid
view anterior
wait
orbit 360 $frames
quit
SCRIPT
run=("$viewer" --size 1280x800 --script "$work/orbit.txt" --frame-log "$work/frames.csv")
if [ -z "${DISPLAY:-}" ]; then
  run=(xvfb-run -a -s "-screen 0 1600x1200x24" "${run[@]}")
fi
"${run[@]}" 2>"$work/stderr.txt" || { cat "$work/stderr.txt" >&2; exit 1; }
# The orbit is the last FRAMES rows of the log.
percentile() {  # column, fraction
  tail -n "$frames" "$work/frames.csv" | cut -d, -f"$1" | sort -g |
    awk -v p="$2" '{v[NR]=$1} END {i=int(p*(NR-1)+0.5)+1; print v[i]}'
}
cpu="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
echo "fabrica-viewer orbit: $frames frames at 1280x800, igea, contour+suggestive+apparent ($mode)"
echo "cpu: $cpu ($(nproc) cores)"
echo "frame ms: median $(percentile 2 0.5), p95 $(percentile 2 0.95)"
echo "draw ms (render + readback + UI): median $(percentile 3 0.5), p95 $(percentile 3 0.95)"
echo "lines ms (worker): median $(percentile 4 0.5), p95 $(percentile 4 0.95)"
echo "lines age (frames): max $(tail -n "$frames" "$work/frames.csv" | cut -d, -f5 | sort -g | tail -1)"
