#!/usr/bin/env bash
# Interleaved A/B timing of two builds with drive_lines: the shared build
# machines swing by ±15 % between identical runs, in regimes that last
# minutes, so compare binaries in alternation and read the minimum (and
# median) of their per-run 10th percentiles.
#
#   bench/ab_drive.sh OLD_BUILD_DIR NEW_BUILD_DIR [VIEWS] [THREADS] [ROUNDS] [rtsc|light]
#
# e.g. with the previous commit in a worktree:
#   git worktree add ../wt-prev HEAD~1 && cmake -S ../wt-prev -B ../wt-prev/build -G Ninja \
#     -DCMAKE_BUILD_TYPE=Release && ninja -C ../wt-prev/build drive_lines
#   bench/ab_drive.sh ../wt-prev/build build 8 2 10
# Both builds must print the same hash when the change keeps the lines.
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,13p' "$0"
  exit 2
fi
old="$1" new="$2" views="${3:-8}" threads="${4:-2}" rounds="${5:-10}" set="${6:-rtsc}"
for n in "$views" "$threads" "$rounds"; do
  if ! [[ "$n" =~ ^[1-9][0-9]*$ ]]; then
    echo "ab_drive: VIEWS, THREADS and ROUNDS must be positive integers (got '$n')" >&2
    exit 2
  fi
done
if [ "$set" != rtsc ] && [ "$set" != light ]; then
  echo "ab_drive: the set is rtsc or light (got '$set')" >&2
  exit 2
fi
for b in "$old" "$new"; do
  if [ ! -x "$b/bench/drive_lines" ]; then
    echo "ab_drive: $b/bench/drive_lines not found (build the drive_lines target)" >&2
    exit 2
  fi
done
tmp="$(mktemp)"
trap 'rm -f "$tmp"' EXIT
for ((r = 0; r < rounds; ++r)); do
  for b in "$old" "$new"; do
    line="$("$b/bench/drive_lines" "$views" "$threads" "$set" | tail -1)"
    # views V threads T segments S hash H median M ms p10 P ms
    echo "$b $(echo "$line" | awk '{ for (i = 1; i < NF; ++i) f[$i] = $(i + 1); print f["hash"], f["p10"] }')" >>"$tmp"
  done
done
for b in "$old" "$new"; do
  hash="$(awk -v b="$b" '$1 == b {print $2}' "$tmp" | sort -u | tr '\n' ' ')"
  awk -v b="$b" '$1 == b {print $3}' "$tmp" | sort -g | awk -v b="$b" -v h="$hash" '
    { p[NR] = $1 }
    END { printf "%-40s hash %s p10 over %d runs: min %.2f ms, median %.2f ms\n", b, h, NR, p[1], p[int((NR + 1) / 2)] }'
done
