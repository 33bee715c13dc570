#!/usr/bin/env bash
# Throughput of the batch workflow on this machine: N tiny synthesised scenes
# (64x48, 4 spp, a caster and a virtual object: prepare, solve, composite and
# eval per item, one thread per job), run locally (snakemake --cores C) and on
# the one-node Slurm cluster of tests/workflow/slurm_cluster.sh (--profile
# workflow/slurm), each on its own fresh copy of the scenes. Prints items per
# hour for both and the Slurm overhead per job (from sacct -c's Submit, Start
# and End against the stage's own time in its status file). Needs root and
# scripts/install-workflow-deps.sh.
#
#   bash tests/workflow/measure_throughput.sh [N_ITEMS (6)] [CORES (2)] [SHADOWSG_BINARY]
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
n=${1:-6}
cores=${2:-2}
bin=$(realpath "${3:-$repo/build/shadowsg}")
work=$(mktemp -d "${TMPDIR:-/tmp}/shadowsg-throughput.XXXXXX")
trap 'bash "$repo/tests/workflow/slurm_cluster.sh" stop "$work/cluster" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
export USER=${USER:-$(id -un)}
casters=('{"primitive": "box", "half_extents": [0.3, 0.3, 0.3]}'
         '{"primitive": "cylinder", "radius": 0.25, "height": 0.6, "segments": 24}'
         '{"primitive": "icosphere", "radius": 0.3, "subdivisions": 2}')
for mode in local slurm; do
  mkdir -p "$work/$mode"
  : > "$work/$mode/manifest.txt"
  for i in $(seq "$n"); do
    sy=$(awk "BEGIN {print -0.6 + 0.15 * $i}")
    cat > "$work/spec$i.json" <<SPEC
{"format": "synth/1",
 "camera": {"width": 64, "height": 48, "fov_deg": 50, "look_from": [1.5, -2.6, 1.6], "look_at": [0.1, 0.0, 0.35]},
 "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [10, 10, 1], "diffuse": [0.8, 0.8, 0.8]},
 "objects": [{"mesh": ${casters[$((i % 3))]}, "rest_on_plane": true, "diffuse": [0.7, 0.7, 0.7]},
             {"mesh": {"primitive": "icosphere", "radius": 0.18, "subdivisions": 2}, "name": "ball",
              "position": [0.75, -0.55, 0], "rest_on_plane": true, "diffuse": [0.65, 0.3, 0.25], "is_train": false}],
 "lights": {"suns": [{"direction": [-0.65, $sy, 0.62], "irradiance": [3.0, 2.8, 2.5]}],
            "lobes": [{"axis": [0, 0, 1], "sharpness": 1.5, "amplitude": [0.25, 0.35, 0.6]}]},
 "render": {"spp": 4, "bounces": 2, "seed": $i}, "env_gt_height": 16}
SPEC
    "$bin" synth "$work/spec$i.json" --out "$work/$mode/scenes/item$i" --threads 1 --quiet
    echo "scenes/item$i" >> "$work/$mode/manifest.txt"
  done
done
cat > "$work/config.yaml" <<CONF
shadowsg: $bin
threads: 1
composite_spp: 4
mem_mb: {prepare: 500, solve: 1000, composite: 1000, eval: 500, run: 1000, summary: 500}
CONF
run() {  # run MODE [snakemake options]: prints the wall seconds
  local mode=$1
  shift
  local t0 t1
  t0=$(date +%s.%N)
  (cd "$work/$mode" && snakemake -s "$repo/workflow/Snakefile" --configfile "$work/config.yaml" \
     --config manifest="$work/$mode/manifest.txt" out=out "$@") > "$work/$mode.log" 2>&1 ||
    { tail -20 "$work/$mode.log" >&2; exit 1; }
  t1=$(date +%s.%N)
  awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.1f", b - a}'
}
load0=$(cut -d' ' -f1-3 /proc/loadavg)
t_local=$(run local --cores "$cores")
eval "$(bash "$repo/tests/workflow/slurm_cluster.sh" start "$work/cluster")"
export SLURM_CONF
t_slurm=$(run slurm --profile "$repo/workflow/slurm")
load1=$(cut -d' ' -f1-3 /proc/loadavg)
jobs_local=$(grep -c '^Finished job' "$work/local.log")
ids=$(sed -n "s/.*has been submitted with SLURM jobid \([0-9]*\).*/\1/p" "$work/slurm.log")
sacct -c -P -n --format=JobID,JobName,Submit,Start,End > "$work/sacct.txt"
python3 - "$work" "$n" "$cores" "$t_local" "$t_slurm" "$jobs_local" "$(echo $ids)" "$load0" "$load1" <<'PY'
import datetime, glob, json, statistics, sys
work, n, cores, t_local, t_slurm, jobs_local, ids, load0, load1 = sys.argv[1:]
n, cores, t_local, t_slurm = int(n), int(cores), float(t_local), float(t_slurm)
ids = ids.split()
ts = lambda s: datetime.datetime.fromisoformat(s).timestamp()
acct = {l.split("|")[0]: l.split("|") for l in open(f"{work}/sacct.txt").read().split("\n") if l}
stage_s = {}
for f in glob.glob(f"{work}/slurm/out/items/*/*.json"):
    st = json.load(open(f))
    if st.get("slurm_job_id"):
        stage_s[st["slurm_job_id"]] = st.get("seconds", 0)
queue = [ts(acct[i][3]) - ts(acct[i][2]) for i in ids if i in acct]
injob = [ts(acct[i][4]) - ts(acct[i][3]) - stage_s[i] for i in ids if i in acct and i in stage_s]
print(f"items: {n} (64x48, 4 spp; prepare+solve+composite+eval, 1 thread per job), {cores} cores; "
      f"load average before {load0}, after {load1}")
print(f"local (snakemake --cores {cores}): {t_local:.1f} s, {jobs_local} jobs -> {3600 * n / t_local:.0f} items/hour")
print(f"slurm (one node, --profile):     {t_slurm:.1f} s, {len(ids)} jobs submitted -> {3600 * n / t_slurm:.0f} items/hour")
print(f"overhead per Slurm job: {(t_slurm - t_local) * cores / max(len(ids), 1):.1f} s of a job slot "
      f"((slurm - local wall) x {cores} slots / jobs); submit to start: median {statistics.median(queue):.0f} s, "
      f"max {max(queue):.0f} s; in the job beyond the stage's own time: median {statistics.median(injob):.1f} s "
      f"(sacct's times are whole seconds)")
PY
