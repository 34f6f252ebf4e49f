#!/usr/bin/env bash
# Time to the first lines and per-view cost, fabrica against rtsc, side by
# side (issue 22): rtsc_bench (rtsc 1.6 built headless; optional tooling,
# never needed by the tests) and bench/drive_lines on the same meshes and
# reference views (c3d_igea_v1, c3d_stanford-bunny_v1), interleaved
# (rtsc, fabrica 1T, fabrica 2T, per mesh, per round), with a check before
# and after each round that both cores are free. Prints medians, minima and
# ratios as a Markdown table for docs/PERFORMANCE.md.
#
#   bench/rtsc_side_by_side.sh [--rtsc PATH] [--build DIR] [--rounds N] [--min-scaling S]
#                              [--max-tries T]
#
#   --rtsc PATH      rtsc_bench; default: $RTSC_BENCH
#   --build DIR      fabrica build with bench/drive_lines (default: build)
#   --rounds N       clean rounds wanted (default 10)
#   --min-scaling S  a round counts only when two copies of a calibration loop
#                    run at >= S times the throughput of one, before and after
#                    the round (default 1.8; both cores free gives ~2.0)
#   --max-tries T    stop after T rounds in all, clean or not (default 4 N)
#
# Compared: rtsc's pre_with_adjfaces (what main() does after reading the
# mesh, plus the face adjacency of its first view) + one view5 (five
# families), against fabrica's precompute_ms (Surface + topology +
# everything Surface::precompute() computes) + first_view_ms (the first view
# of the five families, its view-independent line precompute included);
# per view: rtsc view5 against drive_lines' per-view median. Mesh loading is
# excluded on both sides. rtsc is single-threaded.
set -euo pipefail
usage() {
  sed -n '2,27p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
}
rtsc="${RTSC_BENCH:-}" build=build rounds=10 min_scaling=1.8 max_tries=""
while [ $# -gt 0 ]; do
  case "$1" in
    --rtsc) rtsc="${2:-}"; shift 2 ;;
    --build) build="${2:-}"; shift 2 ;;
    --rounds) rounds="${2:-}"; shift 2 ;;
    --min-scaling) min_scaling="${2:-}"; shift 2 ;;
    --max-tries) max_tries="${2:-}"; shift 2 ;;
    -h | --help) usage ;;
    *) echo "rtsc_side_by_side: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
fail() { echo "rtsc_side_by_side: $*" >&2; exit 2; }
[ -n "$rtsc" ] || fail "no rtsc_bench: pass --rtsc PATH or set RTSC_BENCH"
[ -x "$rtsc" ] || fail "rtsc_bench '$rtsc' is not an executable file (--rtsc / RTSC_BENCH)"
drive="$build/bench/drive_lines"
[ -x "$drive" ] || fail "$drive not found (build the drive_lines target, or pass --build DIR)"
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || fail "--rounds must be a positive integer (got '$rounds')"
[[ "$min_scaling" =~ ^[0-9]+(\.[0-9]+)?$ ]] || fail "--min-scaling must be a number (got '$min_scaling')"
max_tries="${max_tries:-$((4 * rounds))}"
[[ "$max_tries" =~ ^[1-9][0-9]*$ ]] || fail "--max-tries must be a positive integer (got '$max_tries')"
meshes="$build/test-data/data/meshes"
[ -d "$meshes" ] || fail "$meshes not found (configure the build: it unpacks the bundled data)"

# name, drive_lines view, mesh, rtsc eye x y z, feature size (bench/igea_view.hpp;
# reference/rtsc/index.tsv)
views=(
  "igea c3d_igea_v1 igea_v1 classic/c3d_igea.ply 0.000535484229 -0.00086883083 0.16167897 0.000873700483"
  "bunny c3d_stanford-bunny_v1 bunny_v1 classic/c3d_stanford-bunny.obj -0.0197627805 0.10807047 0.289503247 0.0021362158"
)
per_view=20 first_reps=3

# Calibration: one busy loop alone, then two at once; the throughput ratio is
# ~2 when both cores are free and ~1 when another process holds one.
spin() { awk 'BEGIN { s = 0; for (i = 0; i < 4000000; ++i) s += sin(i); print s }' >/dev/null; }
now_ns() { date +%s%N; }
scaling() {
  local a b c
  a=$(now_ns); spin; b=$(now_ns)
  spin & spin & wait
  c=$(now_ns)
  awk -v one=$((b - a)) -v two=$((c - b)) 'BEGIN { printf "%.2f", 2 * one / two }'
}
ok() { awk -v s="$1" -v m="$min_scaling" 'BEGIN { exit !(s >= m) }'; }

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
raw="$tmp/raw"
: >"$raw"
load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
start="$(date -u '+%Y-%m-%d %H:%M UTC')"
clean=0 tries=0 scalings=""
while [ "$clean" -lt "$rounds" ] && [ "$tries" -lt "$max_tries" ]; do
  tries=$((tries + 1))
  before="$(scaling)"
  if ! ok "$before"; then
    echo "round $tries: cores busy (2-copy scaling $before < $min_scaling), waiting" >&2
    sleep 5
    continue
  fi
  round="$tmp/round"
  : >"$round"
  for v in "${views[@]}"; do
    read -r name ref dview mesh ex ey ez fs <<<"$v"
    out="$("$rtsc" "$meshes/$mesh" "$ex" "$ey" "$ez" "$fs" "$per_view" "$first_reps" 1)"
    pre="$(awk '$1 == "pre_with_adjfaces_median_ms" { print $2 }' <<<"$out")"
    view="$(awk '$1 == "view5_median_ms" { print $2 }' <<<"$out")"
    [ -n "$pre" ] && [ -n "$view" ] || fail "rtsc_bench printed no pre_with_adjfaces/view5 times on $mesh"
    echo "$name rtsc $pre 0 $view" >>"$round"
    for t in 1 2; do
      line="$("$drive" "$per_view" "$t" rtsc "$dview" "$first_reps" | tail -1)"
      # views V threads T segments S hash H median M ms p10 P ms precompute_ms X first_view_ms Y
      awk -v n="$name" -v t="$t" '{
        for (i = 1; i < NF; ++i) f[$i] = $(i + 1)
        print n, "fabrica" t "T", f["precompute_ms"], f["first_view_ms"], f["median"], f["hash"] }' \
        <<<"$line" >>"$round"
    done
  done
  after="$(scaling)"
  if ! ok "$after"; then
    echo "round $tries: cores busy after the round (scaling $after), discarded" >&2
    continue
  fi
  cat "$round" >>"$raw"
  clean=$((clean + 1))
  scalings="$scalings $before $after"
  echo "round $tries: clean ($clean/$rounds), scaling $before / $after" >&2
done
load_after="$(cut -d' ' -f1-3 /proc/loadavg)"
[ "$clean" -gt 0 ] || fail "no clean round in $tries tries: the cores were never free (try later, or --min-scaling lower)"

cpu="$(awk -F': *' '/^model name/ { n = $2 } /^cpu family/ { f = $2 } /^model\t/ { m = $2 }
  /^flags/ { x = ($2 ~ /avx512f/) ? ", AVX-512" : (($2 ~ /avx2/) ? ", AVX2" : ""); exit }
  END { printf "%s (family %s, model %s%s)", n, f, m, x }' /proc/cpuinfo)"
range="$(tr ' ' '\n' <<<"$scalings" | sed '/^$/d' | sort -g | sed -n '1p;$p' | tr '\n' ' ')"
echo
echo "CPU: $cpu ($(nproc) cores); $start; $clean clean rounds of $tries (interleaved: rtsc, fabrica 1T, fabrica 2T per mesh);"
echo "calibration scaling (2 copies / 1) min/max: $range(a round counts when >= $min_scaling before and after); load average before: $load_before, after: $load_after"
if awk -v m="$min_scaling" 'BEGIN { exit !(m < 1.8) }'; then
  echo "WARNING: --min-scaling $min_scaling is below 1.8: the cores were not checked free, these are loaded-machine figures"
fi
echo "fabrica: $(git -C "$(dirname "$0")" rev-parse --short HEAD 2>/dev/null || echo '?'), hashes: $(awk '$2 ~ /fabrica/ { print $1 "=" $6 }' "$raw" | sort -u | tr '\n' ' ')"
echo
# Medians and minima per mesh and program; first = pre + first view.
awk '
  function med(a, n,   i, j, t) {
    for (i = 2; i <= n; ++i) for (j = i; j > 1 && a[j - 1] > a[j]; --j) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
    return n % 2 ? a[(n + 1) / 2] : 0.5 * (a[n / 2] + a[n / 2 + 1])
  }
  function mn(a, n,   i, m) { m = a[1]; for (i = 2; i <= n; ++i) if (a[i] < m) m = a[i]; return m }
  {
    k = $1 SUBSEP $2; c = ++cnt[k]
    P[k, c] = $3; F[k, c] = $4; V[k, c] = $5
    T[k, c] = $3 + ($2 == "rtsc" ? $5 : $4)  # rtsc: pre_with_adjfaces + view5
    if (!($1 in seen)) { seen[$1] = 1; order[++nm] = $1 }
  }
  function stat(arr, k, which,   i, n, a) {
    n = cnt[k]; for (i = 1; i <= n; ++i) a[i] = arr[k, i]
    return which == "min" ? mn(a, n) : med(a, n)
  }
  function cell(arr, k) { return sprintf("%.1f / %.1f", stat(arr, k, "med"), stat(arr, k, "min")) }
  END {
    print "Medians / minima in ms over the clean rounds (first lines: of the per-round sums); ratios from the medians (minima in brackets)."
    print "first lines = precompute + first view (rtsc: pre_with_adjfaces + view5); target <= 0.5 (1T), <= 0.3 (2T)."
    print "per view = five families, steady state; target rtsc / fabrica >= 4 (1T), >= 7 (2T)."
    print ""
    print "| mesh | | rtsc 1T | fabrica 1T | fabrica 2T | fabrica 1T / rtsc | fabrica 2T / rtsc |"
    print "|---|---|---|---|---|---|---|"
    for (m = 1; m <= nm; ++m) {
      name = order[m]; r = name SUBSEP "rtsc"; f1 = name SUBSEP "fabrica1T"; f2 = name SUBSEP "fabrica2T"
      printf "| %s | precompute | %s | %s | %s | | |\n", name, cell(P, r), cell(P, f1), cell(P, f2)
      printf "| | first view | %s | %s | %s | | |\n", cell(V, r), cell(F, f1), cell(F, f2)
      printf "| | **first lines** | %s | %s | %s | **%.2f** (%.2f) | **%.2f** (%.2f) |\n", \
        cell(T, r), cell(T, f1), cell(T, f2), \
        stat(T, f1, "med") / stat(T, r, "med"), stat(T, f1, "min") / stat(T, r, "min"), \
        stat(T, f2, "med") / stat(T, r, "med"), stat(T, f2, "min") / stat(T, r, "min")
      printf "| | per view | %s | %s | %s | rtsc / fabrica: **%.2f** (%.2f) | **%.2f** (%.2f) |\n", \
        cell(V, r), cell(V, f1), cell(V, f2), \
        stat(V, r, "med") / stat(V, f1, "med"), stat(V, r, "min") / stat(V, f1, "min"), \
        stat(V, r, "med") / stat(V, f2, "med"), stat(V, r, "min") / stat(V, f2, "min")
    }
  }' "$raw"
