#!/usr/bin/env bash
# Time and peak memory of `fabrica lines` (load + precompute + one view of
# the five rtsc families + chaining + hidden-line removal + SVG) from about
# 100k to 2M faces: meshes made from one small mesh by bench/scale_mesh
# (midpoint and centroid splits, so the shape stays the same), each run
# under /usr/bin/time -v (maximum resident set, wall time and CPU time = user + system: on a
# loaded machine the wall time waits for the cores, the CPU time does not); the
# minimum over ROUNDS runs per size. Prints one row per size and the bytes
# per face above the binary's own footprint (`fabrica --version`).
# With RTSC=path/to/rtsc_bench in the environment (optional tooling, see
# docs/PERFORMANCE.md), rtsc's maximum resident set on the same mesh (as
# OFF: its reader takes no double PLY) is printed beside it: one view of
# the five families from 3 radii in front (-y, anterior in LPS) at the
# bounding box's centre, feature size radius / 50, no chaining, hidden
# lines or SVG.
#
#   bench/scale_lines.sh BUILD_DIR [MESH=data/aneurysm.off] [THREADS=1] [ROUNDS=3]
#
# With aneurysm.off (14,186 faces) the sizes are 128k, 227k, 511k, 908k and
# 2.04M faces (split steps 33, 44, 334, 444, 3344).
set -euo pipefail
if [ $# -lt 1 ]; then
  sed -n '2,13p' "$0"
  exit 2
fi
build="$1" mesh="${2:-data/aneurysm.off}" threads="${3:-1}" rounds="${4:-3}"
for n in "$threads" "$rounds"; do
  if ! [[ "$n" =~ ^[1-9][0-9]*$ ]]; then
    echo "scale_lines: THREADS and ROUNDS must be positive integers (got '$n')" >&2
    exit 2
  fi
done
fabrica="$build/apps/fabrica/fabrica" scale="$build/bench/scale_mesh"
for x in "$fabrica" "$scale"; do
  if [ ! -x "$x" ]; then
    echo "scale_lines: $x not found (build the fabrica and scale_mesh targets)" >&2
    exit 2
  fi
done
if [ ! -r "$mesh" ]; then
  echo "scale_lines: cannot read the mesh '$mesh'" >&2
  exit 2
fi
if [ ! -x /usr/bin/time ]; then
  echo "scale_lines: /usr/bin/time is needed (Debian package 'time')" >&2
  exit 2
fi
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
# One run: "wall_s cpu_s maxrss_kB" (cpu: user + system).
measure() {
  /usr/bin/time -v "$@" 2>"$tmp/time" >/dev/null
  awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); w = 0; for (i = 1; i <= n; ++i) w = w * 60 + t[i]}
              /User time|System time/ {u += $2} /Maximum resident/ {r = $2} END {print w, u, r}' "$tmp/time"
}
base_kb="$(measure "$fabrica" --version | awk '{print $3}')"
echo "# $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u '+%F %H:%M UTC');" \
  "load $(cut -d' ' -f1-3 /proc/loadavg); threads $threads; min of $rounds runs"
echo "# binary alone (fabrica --version): $((base_kb / 1024)) MB"
rtsc="${RTSC:-}"
if [ -n "$rtsc" ] && [ ! -x "$rtsc" ]; then
  echo "scale_lines: RTSC=$rtsc is not an executable" >&2
  exit 2
fi
printf '%10s %10s %9s %9s %9s %11s%s\n' faces vertices wall_s cpu_s rss_MB "B/face>base" \
  "${rtsc:+ rtsc_rss_MB}"
for steps in 33 44 334 444 3344; do
  counts="$("$scale" "$mesh" "$tmp/m.ply" "$steps")"
  vertices="$(echo "$counts" | awk '{print $2}')" faces="$(echo "$counts" | awk '{print $4}')"
  rtsc_mb=""
  if [ -n "$rtsc" ]; then
    "$scale" "$mesh" "$tmp/m.off" "$steps" >/dev/null
    read -r cx cy cz r <<<"$(echo "$counts" | awk '{print $6, $7, $8, $10}')"
    eye="$(awk -v x="$cx" -v y="$cy" -v z="$cz" -v r="$r" 'BEGIN {print x, y - 3 * r, z, r / 50}')"
    # shellcheck disable=SC2086  # eye: four numbers
    rtsc_mb="$(measure "$rtsc" "$tmp/m.off" $eye 1 1 1 | awk '{printf " %11.1f", $3 / 1024}')"
  fi
  for ((r = 0; r < rounds; ++r)); do
    measure "$fabrica" lines "$tmp/m.ply" -o "$tmp/out.svg" --types reference \
      --threads "$threads" -q
  done | sort -g -k3 | awk -v f="$faces" -v v="$vertices" -v b="$base_kb" '
    NR == 1 || $1 < w {w = $1} NR == 1 || $2 < u {u = $2} NR == 1 || $3 < r {r = $3}
    END {printf "%10d %10d %9.2f %9.2f %9.1f %11.0f", f, v, w, u, r / 1024, (r - b) * 1024 / f}'
  echo "$rtsc_mb"
done
