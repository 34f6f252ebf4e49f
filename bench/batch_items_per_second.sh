#!/usr/bin/env bash
# Items per second of `fabrica batch` on the bundled demo (data/aneurysm.off)
# at 1024x1024: one input, an orbit of 8 views, two styles (feature lines as
# SVG; a shaded PNG with contour + suggestive + apparent lines plus its SVG),
# 16 items. Prints the CPU, the wall time and items/s for --jobs 1 and the
# default (every core); each run starts from an empty folder.
#   bench/batch_items_per_second.sh [BUILD_DIR]    (default: build)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$root/build}
exe=$build/apps/fabrica/fabrica
work=$(mktemp -d /tmp/fabrica-batch-bench-XXXXXX)
trap 'rm -rf "$work"' EXIT
cat > "$work/manifest.json" <<JSON
{"inputs": [{"mesh": "$root/data/aneurysm.off"}],
 "views": [{"orbit": 8}],
 "styles": [{"name": "lines", "command": "lines", "types": ["contour", "suggestive", "apparent"], "formats": ["svg"]},
            {"name": "shaded", "command": "render", "lines": ["contour", "suggestive", "apparent"], "formats": ["png", "svg"]}],
 "size": [1024, 1024]}
JSON
echo "cpu: $(lscpu | sed -n 's/^Model name: *//p' | head -n 1), $(nproc) cores"
for jobs in 1 "$(nproc)"; do
  rm -rf "$work/out"
  start=$(date +%s.%N)
  "$exe" batch "$work/manifest.json" -o "$work/out" --jobs "$jobs" --quiet
  end=$(date +%s.%N)
  awk -v s="$start" -v e="$end" -v j="$jobs" \
    'BEGIN { t = e - s; printf "--jobs %d: 16 items in %.2f s = %.2f items/s\n", j, t, 16 / t }'
done
