#!/usr/bin/env bash
# A real Slurm run of `fabrica batch` (issue 19): starts a one-node cluster on
# localhost (slurm-cluster.sh), submits a manifest over bundled meshes as a job
# array of 3 tasks with --shard auto, waits (bounded), merges the shard
# reports and checks them and every output byte against a run on this
# machine without Slurm. Stops the cluster whatever happens.
#   test_slurm.sh FABRICA_EXE TEST_DATA_DIR WORK_DIR
set -euo pipefail
exe=$1 data=$2 work=$3
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ "$(id -u)" -ne 0 ] || ! command -v slurmctld >/dev/null; then
  # CI runs as root after scripts/setup installed slurm-wlm: never skipped there.
  if [ -n "${CI:-}" ]; then echo "test_slurm: needs root and slurm-wlm (scripts/setup)" >&2; exit 1; fi
  echo "test_slurm: skipped (needs root and Debian's slurm-wlm + munge: scripts/setup)"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work"
ln -s "$data" "$work/data"
cat > "$work/manifest.json" <<'JSON'
{"inputs": [{"mesh": "data/meshes/anatomy/liver/sofa_liver_coarse.obj"},
            {"mesh": "data/meshes/anatomy/brain/vtkdata_mni-surface-mesh.off"}],
 "views": ["anterior", "left", {"orbit": 2}],
 "styles": [{"name": "lines", "command": "lines", "types": ["contour", "suggestive"], "formats": ["svg"]},
            {"name": "ridges", "command": "lines", "types": "ridge,valley", "formats": ["json"]}],
 "size": [256, 256]}
JSON
# The reference: the whole manifest on this machine.
"$exe" batch "$work/manifest.json" -o "$work/single" --quiet

cluster=$work/cluster-state
trap '"$here/slurm-cluster.sh" stop "$cluster"' EXIT
"$here/slurm-cluster.sh" start "$cluster"
export SLURM_CONF=$cluster/slurm.conf
job=$(sbatch --parsable --array=0-2 --cpus-per-task=1 --chdir="$work" --output="$work/task-%a.log" \
  --wrap "'$exe' batch '$work/manifest.json' -o '$work/out' --shard auto --quiet")
echo "test_slurm: submitted job array $job"
for _ in $(seq 600); do
  [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] && break
  sleep 0.5
done
if [ -n "$(squeue -h -j "$job" 2>/dev/null)" ]; then
  echo "test_slurm: job $job still queued or running after 300 s" >&2
  squeue >&2 || true
  cat "$work"/task-*.log >&2 || true
  exit 1
fi
cat "$work"/task-*.log
for i in 0 1 2; do
  [ -s "$work/out/batch-report-$i-of-3.json" ] || { echo "test_slurm: task $i left no report" >&2; exit 1; }
done
# The merged report: every item made (exit 0 means none failed or missing).
"$exe" batch merge "$work/out"
grep -q '"total_items": 16' "$work/out/batch-report.json"
grep -q '"made": 16' "$work/out/batch-report.json"
# Every output and its metadata, byte for byte as on one machine.
diff -r -x 'batch-report*' -x .batch "$work/single" "$work/out"
[ "$(find "$work/out" -name '*.svg' | wc -l)" -eq 8 ]
echo "test_slurm: 3 array tasks made the same 16 items as one machine"
