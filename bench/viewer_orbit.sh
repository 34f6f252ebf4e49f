#!/usr/bin/env bash
# fabrica-viewer orbit benchmark (issue 18, "Speed"): 120 frames at 1280x800
# turning once around the bundled igea (c3d_igea.ply, 134k vertices, the
# focus) with contours, suggestive contours and apparent ridges recomputed
# for every frame, plus ghosted context structures:
#   300k  two context structures of 300,508 faces in all (the Stanford bunny
#         subdivided once, 277,804 faces, and the camel head, 22,704 faces,
#         both placed around the igea by bench/make_context)
#   1m    one context of 1,111,216 faces (the bunny subdivided twice)
#   none  the igea alone
# Prints, per configuration, the median and 95th percentile of the frame time
# (and of the drawing and the lines' time) from the viewer's frame log, the
# CPU time per orbit frame of the whole process (all threads, llvmpipe's
# included: what a shared machine's load inflates much less than the wall
# clock), and the load average. Not a
# timed test: record the figures in docs/PERFORMANCE.md.
#
#   bench/viewer_orbit.sh [BUILD_DIR] [FRAMES] [object|hybrid|both] [none|300k|1m|all] [full|coarse]
#
# The last argument (default full): while the camera moves the focus is drawn
# from a coarser copy and its lines come from the full mesh (full) or from
# that copy (coarse: the viewer's `moving-lines coarse`).
# Defaults: build 120 both all (the issue's figures: 300k and 1m contexts,
# object-space and hybrid GPU apparent ridges, and the igea alone).
# Without a display the viewer runs under xvfb-run.
set -euo pipefail
build="${1:-build}" frames="${2:-120}" modes="${3:-both}" contexts="${4:-all}"
moving_lines="${5:-full}"
case "$moving_lines" in full | coarse) ;;
*) echo "viewer_orbit: moving lines must be full or coarse (got '$moving_lines')" >&2; exit 2 ;; esac
if ! [[ "$frames" =~ ^[1-9][0-9]*$ ]]; then
  echo "viewer_orbit: FRAMES must be a positive integer (got '$frames')" >&2
  exit 2
fi
case "$modes" in object | hybrid) ;; both) modes="object hybrid" ;;
*) echo "viewer_orbit: mode must be object, hybrid or both (got '$modes')" >&2; exit 2 ;; esac
case "$contexts" in none | 300k | 1m) ;; all) contexts="300k 1m none" ;;
*) echo "viewer_orbit: context must be none, 300k, 1m or all (got '$contexts')" >&2; exit 2 ;; esac
viewer="$build/apps/viewer/fabrica-viewer"
make_context="$build/bench/make_context"
data="$build/test-data/data/meshes/classic"
mesh="$data/c3d_igea.ply"
for f in "$viewer" "$make_context" "$mesh"; do
  if [ ! -e "$f" ]; then
    echo "viewer_orbit: $f is missing; build fabrica-viewer and make_context in $build first" >&2
    exit 2
  fi
done
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$make_context" "$data/c3d_stanford-bunny.obj" "$mesh" "$work/skin.ply" 1 1.5 >/dev/null
"$make_context" "$data/libigl_camelhead.off" "$mesh" "$work/shell.ply" 0 1.2 >/dev/null
"$make_context" "$data/c3d_stanford-bunny.obj" "$mesh" "$work/skin_fine.ply" 2 1.5 >/dev/null

percentile() {  # log, column, fraction
  tail -n "$frames" "$1" | cut -d, -f"$2" | sort -g |
    awk -v p="$3" '{v[NR]=$1} END {i=int(p*(NR-1)+0.5)+1; printf "%.1f", v[i]}'
}
# One run; the viewer prints the orbit's CPU time per frame (getrusage of
# the whole process over the orbit's frames: every thread, the lines
# worker's and llvmpipe's included, loading excluded).
run_viewer() {  # script, log -> prints the orbit's CPU ms per frame
  local cmd=("$viewer" --size 1280x800 --script "$1" --frame-log "$2")
  if [ -z "${DISPLAY:-}" ]; then
    cmd=(xvfb-run -a -s "-screen 0 1600x1200x24" "${cmd[@]}")
  fi
  "${cmd[@]}" >"$work/stdout.txt" 2>"$work/stderr.txt" ||
    { cat "$work/stderr.txt" >&2; exit 1; }
  sed -n 's/^orbit: .*cpu \([0-9.]*\) ms per frame.*/\1/p' "$work/stdout.txt" | tail -1
}
cpu="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
echo "fabrica-viewer orbit: $frames frames at 1280x800 around the igea (focus), contour+suggestive+apparent, focus lines while moving: $moving_lines"
echo "cpu: $cpu ($(nproc) cores); GL: llvmpipe, LP_NUM_THREADS=${LP_NUM_THREADS:-default}"
for context in $contexts; do
  for mode in $modes; do
    hybrid=false
    [ "$mode" = hybrid ] && hybrid=true
    opens="open \"$mesh\""
    case "$context" in
      300k) opens+=$'\n'"open \"$work/skin.ply\""$'\n'"open \"$work/shell.ply\"" ;;
      1m) opens+=$'\n'"open \"$work/skin_fine.ply\"" ;;
    esac
    setting=""
    [ "$moving_lines" = coarse ] && setting=$'\n'"moving-lines coarse"
    cat >"$work/orbit.txt" <<SCRIPT
$opens$setting
wait
focus c3d_igea
set c3d_igea lines=contour,suggestive,apparent hybrid=$hybrid
view anterior
wait
orbit 360 $frames
quit
SCRIPT
    load="$(cut -d' ' -f1-3 /proc/loadavg)"
    cpu_ms="$(run_viewer "$work/orbit.txt" "$work/frames.csv")"
    log="$work/frames.csv"
    echo "-- context $context, apparent ridges $mode (load average $load)"
    echo "frame ms: median $(percentile "$log" 2 0.5), p95 $(percentile "$log" 2 0.95)"
    echo "draw ms (render + UI + swap): median $(percentile "$log" 3 0.5), p95 $(percentile "$log" 3 0.95)"
    echo "lines ms (worker): median $(percentile "$log" 4 0.5), p95 $(percentile "$log" 4 0.95)"
    echo "cpu ms per frame (all threads): $cpu_ms"
    median="$(percentile "$log" 2 0.5)" p95="$(percentile "$log" 2 0.95)"
    case "$context" in
      300k) target_median=33 target_p95=50 ;;
      1m) target_median=66 target_p95= ;;
      *) target_median= target_p95= ;;
    esac
    if [ -n "$target_median" ]; then
      verdict="$(awk -v m="$median" -v p="$p95" -v tm="$target_median" -v tp="${target_p95:-1e300}" \
        'BEGIN {print (m <= tm && p <= tp) ? "met" : "not met"}')"
      echo "issue 18 target: median <= $target_median ms${target_p95:+, p95 <= $target_p95 ms}: $verdict" \
        "(median $median, p95 $p95; on $(nproc) cores a frame takes at least cpu / $(nproc) = $(awk -v c="$cpu_ms" -v n="$(nproc)" 'BEGIN {printf "%.1f", c / n}') ms)"
    fi
    echo "lines age (frames): max $(tail -n "$frames" "$log" | cut -d, -f5 | sort -g | tail -1)"
  done
done
