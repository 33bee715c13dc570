#!/usr/bin/env bash
# The batch workflow (workflow/Snakefile) end to end, locally and on a real
# one-node Slurm cluster started on localhost (README "Batch runs").
#
#   bash tests/workflow/test_workflow.sh [--install] [SHADOWSG_BINARY]
#
#  1. synthesises 3 tiny scenes (64x48, 4 spp; two with a virtual object) and a
#     bad item (a broken scene.json);
#  2. runs the workflow locally (snakemake --cores 2): the good items finish, the
#     bad one fails alone (its `check` job, with shadowsg's error) and the
#     summary (index.html, results.csv, items.csv, failed.csv) lists it;
#  3. reruns: only the failed item's jobs and the summary run again;
#  4. starts slurmctld + slurmd + munged on localhost (tests/workflow/slurm_cluster.sh),
#     runs the workflow with --profile workflow/slurm into another folder, checks
#     that sacct accounts for every submitted job and that every result equals
#     the local run's (timing keys and output paths aside);
#  5. drops the bad item from the manifest: one run rewrites the summary, the next
#     has nothing to do; stops the daemons (also on failure).
#
# --install first installs the Debian packages (scripts/install-workflow-deps.sh);
# without it, missing snakemake or Slurm skips the test (exit status 77), as does
# a user other than root (the Slurm daemons run as root). KEEP=1 keeps the work folder.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
install=0
bin=""
for a in "$@"; do
  case "$a" in
    --install) install=1 ;;
    *) bin=$a ;;
  esac
done
[ "$install" = 1 ] && bash "$repo/scripts/install-workflow-deps.sh"
bin=$(realpath "${bin:-$repo/build/shadowsg}")
[ -x "$bin" ] || { echo "test_workflow: $bin: no shadowsg binary (build first)" >&2; exit 1; }
for c in snakemake sbatch sacct slurmctld slurmd munged; do
  command -v "$c" >/dev/null || { echo "SKIP: $c is not installed (bash scripts/install-workflow-deps.sh)"; exit 77; }
done
[ "$(id -u)" -eq 0 ] || { echo "SKIP: the one-node Slurm cluster needs root"; exit 77; }

work=$(mktemp -d "${TMPDIR:-/tmp}/shadowsg-workflow.XXXXXX")
cluster="$work/cluster"
cleanup() {
  bash "$repo/tests/workflow/slurm_cluster.sh" stop "$cluster" >/dev/null 2>&1 || true
  if [ "${KEEP:-0}" = 1 ]; then echo "test_workflow: kept $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM
export USER=${USER:-$(id -un)}  # Snakemake's Slurm executor reads it
py=python3
t_start=$(date +%s.%N)
secs() { echo "$(date +%s.%N) $1" | awk '{printf "%.1f", $1 - $2}'; }
fail() { echo "FAIL: $*" >&2; exit 1; }
pass() { echo "ok: $*"; }

# ---------------------------------------------------------------- 1. items
mkdir -p "$work/scenes"
for i in 1 2 3; do
  case $i in
    1) caster='{"primitive": "box", "half_extents": [0.3, 0.3, 0.3]}'; sun='[-0.65, -0.45, 0.62]'; virtual=1 ;;
    2) caster='{"primitive": "cylinder", "radius": 0.25, "height": 0.6, "segments": 24}'; sun='[0.6, -0.5, 0.6]'; virtual=0 ;;
    3) caster='{"primitive": "icosphere", "radius": 0.3, "subdivisions": 2}'; sun='[0.5, -0.6, 0.7]'; virtual=1 ;;
  esac
  ball=""
  [ "$virtual" = 1 ] && ball=', {"mesh": {"primitive": "icosphere", "radius": 0.18, "subdivisions": 2}, "name": "ball",
     "position": [0.75, -0.55, 0], "rest_on_plane": true, "diffuse": [0.65, 0.3, 0.25], "is_train": false}'
  cat > "$work/spec$i.json" <<EOF
{"format": "synth/1",
 "camera": {"width": 64, "height": 48, "fov_deg": 50, "look_from": [1.5, -2.6, 1.6], "look_at": [0.1, 0.0, 0.35]},
 "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [10, 10, 1], "diffuse": [0.8, 0.8, 0.8]},
 "objects": [{"mesh": $caster, "rest_on_plane": true, "diffuse": [0.7, 0.7, 0.7]}$ball],
 "lights": {"suns": [{"direction": $sun, "irradiance": [3.0, 2.8, 2.5], "angular_radius_deg": 0.5}],
            "lobes": [{"axis": [0, 0, 1], "sharpness": 1.5, "amplitude": [0.25, 0.35, 0.6]}]},
 "render": {"spp": 4, "bounces": 2, "seed": $i},
 "env_gt_height": 16}
EOF
  "$bin" synth "$work/spec$i.json" --out "$work/scenes/scene$i" --threads 1 --quiet
done
mkdir -p "$work/scenes/broken"
printf '{"camera": ' > "$work/scenes/broken/scene.json"
printf '# test manifest\nscenes/scene1\nscenes/scene2\n\nscenes/broken\nscenes/scene3\n' > "$work/manifest.txt"
cat > "$work/test-config.yaml" <<EOF
manifest: $work/manifest.txt
shadowsg: $bin
threads: 1
composite_spp: 4
mem_mb: {prepare: 500, solve: 1000, composite: 1000, eval: 500, run: 1000, summary: 500}
runtime: {prepare: 10, solve: 10, composite: 10, eval: 10, run: 10, summary: 10}
EOF
pass "items synthesised ($(secs "$t_start") s)"

# ---------------------------------------------------------------- helpers
smk() {  # smk LOG OUT [snakemake options...]: runs the workflow in $work (manifest: $MANIFEST), returns its status
  local log=$1 out=$2
  shift 2
  set +e
  (cd "$work" && timeout 900 snakemake -s "$repo/workflow/Snakefile" --configfile "$work/test-config.yaml" \
     --config "out=$out" "manifest=${MANIFEST:-$work/manifest.txt}" "$@") > "$log" 2>&1
  local rc=$?
  set -e
  return $rc
}
jobs_of() {  # "rule wildcards" of every job a snakemake log started
  awk '/^(local)?rule [a-z_]+:/ {r = $2; sub(":", "", r)} /^    wildcards:/ {print r, $2} /^(local)?rule summary:/ {print "summary"}' "$1" | sort
}
check_run() {  # check_run OUT LOG: the bad item failed alone and the summary lists it
  local out=$1 log=$2
  for s in scene1 scene2 scene3; do
    [ -f "$work/$out/items/$s/ok" ] || fail "$out: $s did not finish ($(cat "$work/$out/items/$s/item.json" 2>/dev/null))"
    [ -s "$work/$out/items/$s/solve/lighting.json" ] || fail "$out: $s has no lighting.json"
    [ -s "$work/$out/items/$s/eval/metrics.json" ] || fail "$out: $s has no eval"
  done
  for s in scene1 scene3; do [ -s "$work/$out/items/$s/composite/composite.exr" ] || fail "$out: $s has no composite"; done
  [ ! -e "$work/$out/items/scene2/composite" ] || fail "$out: scene2 (no virtual object) was composited"
  [ ! -e "$work/$out/items/broken/ok" ] || fail "$out: the broken item passed"
  [ "$(grep -c '^Error in rule' "$log")" = 1 ] || fail "$out: expected one failed job, got: $(grep -A3 '^Error in rule' "$log")"
  grep -A3 '^Error in rule check' "$log" | grep -q 'output: .*/items/broken/ok' || fail "$out: the failed job is not broken's check"
  grep -q "error: item broken .*scene.json: invalid JSON" "$log" || fail "$out: the check job does not say what is wrong"
  grep -q "scene.json: invalid JSON" "$work/$out/logs/broken/prepare.log" || fail "$out: the stage log lacks the error"
  local sum="$work/$out/summary"
  for f in index.html results.csv results.md items.csv failed.csv charts/time_psnr_mean.png; do
    [ -s "$sum/$f" ] || fail "$out: summary/$f missing"
  done
  $py - "$sum" <<'EOF' || fail "$out: the summary does not list the items as expected"
import csv, sys
d = sys.argv[1]
failed = list(csv.DictReader(open(f"{d}/failed.csv")))
assert [r["item"] for r in failed] == ["broken"], failed
assert failed[0]["failed_stage"] == "prepare" and "invalid JSON" in failed[0]["error"], failed
items = {r["item"]: r for r in csv.DictReader(open(f"{d}/items.csv"))}
assert sorted(items) == ["broken", "scene1", "scene2", "scene3"], items
assert all(items[s]["status"] == "ok" and float(items[s]["psnr"]) > 15 for s in ("scene1", "scene2", "scene3")), items
assert items["scene1"]["insert_psnr"] and not items["scene2"]["insert_psnr"], items
rows = {r["scene"]: r for r in csv.DictReader(open(f"{d}/results.csv"))}
assert sorted(rows) == ["broken", "scene1", "scene2", "scene3"], rows
assert "invalid JSON" in rows["broken"]["error"] and not rows["scene1"]["error"], rows
html = open(f"{d}/index.html").read()
assert 'id="failed"' in html and "broken" in html and "invalid JSON" in html and "time_psnr_mean.png" in html
EOF
}

# ---------------------------------------------------------------- 2. local run
t0=$(date +%s.%N)
if smk "$work/local1.log" out-local --cores 2 --keep-going; then fail "the local run succeeded despite the bad item"; fi
t_local=$(secs "$t0")
check_run out-local "$work/local1.log"
n_local=$(jobs_of "$work/local1.log" | wc -l)
pass "local run: $n_local jobs in $t_local s; the bad item failed alone and is listed in the summary"

# ---------------------------------------------------------------- 3. rerun
declare -A before
for f in "$work"/out-local/items/scene*/*.json "$work"/out-local/items/scene*/*/lighting.json; do before[$f]=$(stat -c %Y.%N "$f"); done
t0=$(date +%s.%N)
if smk "$work/local2.log" out-local --cores 2 --keep-going; then fail "the rerun succeeded despite the bad item"; fi
t_rerun=$(secs "$t0")
redone=$(jobs_of "$work/local2.log" | tr '\n' ',')
expected="check item=broken,eval scene=broken,item item=broken,prepare scene=broken,solve scene=broken,summary,"
[ "$redone" = "$expected" ] || fail "rerun redid: $redone (expected $expected)"
for f in "${!before[@]}"; do [ "${before[$f]}" = "$(stat -c %Y.%N "$f")" ] || fail "rerun rewrote $f"; done
check_run out-local "$work/local2.log"
pass "rerun ($t_rerun s): only the failed item and the summary were redone"

# ---------------------------------------------------------------- 4. Slurm
t0=$(date +%s.%N)
eval "$(bash "$repo/tests/workflow/slurm_cluster.sh" start "$cluster")"
export SLURM_CONF
pass "one-node Slurm cluster up in $(secs "$t0") s ($(sinfo -h -N -o '%N %c CPUs %m MB %t'))"
t0=$(date +%s.%N)
if smk "$work/slurm.log" out-slurm --profile "$repo/workflow/slurm"; then fail "the Slurm run succeeded despite the bad item"; fi
t_slurm=$(secs "$t0")
check_run out-slurm "$work/slurm.log"
ids=$(sed -n "s/.*has been submitted with SLURM jobid \([0-9]*\).*/\1/p" "$work/slurm.log" | sort -n)
n_sub=$(echo "$ids" | grep -c . || true)
n_remote=$(jobs_of "$work/slurm.log" | grep -cv '^\(item\|check\) ' || true)  # item and check are local rules
[ "$n_sub" -gt 0 ] && [ "$n_sub" = "$n_remote" ] || fail "submitted $n_sub jobs to Slurm, expected $n_remote"
# Accounting: the job completion log (sacct -c); every submitted job listed, COMPLETED, exit 0.
acct=$(sacct -c -P -n --format=JobID,JobName,State,ExitCode,Elapsed,NodeList)
for id in $ids; do
  line=$(grep "^$id|" <<<"$acct" || true)
  [ -n "$line" ] || fail "sacct does not list Slurm job $id"
  [[ "$line" == "$id|"*"|COMPLETED|0:0|"* ]] || fail "Slurm job $id: $line"
done
# ...and the jobs' status files carry the same ids (the stages ran inside those jobs).
for s in scene1 scene2 scene3; do  # (the broken item's status files were removed by its check job)
  for st in "$work"/out-slurm/items/$s/*.json; do
    [ "$(basename "$st")" = item.json ] && continue
    id=$($py -c "import json,sys; print(json.load(open(sys.argv[1]))['slurm_job_id'])" "$st")
    grep -qx "$id" <<<"$ids" || fail "$st ran outside the submitted jobs (SLURM_JOB_ID $id)"
  done
done
pass "Slurm run: $n_sub jobs submitted, all accounted for by sacct -c, in $t_slurm s"
$py - "$work/out-local" "$work/out-slurm" <<'EOF' || fail "the Slurm run's results differ from the local run's"
import csv, glob, hashlib, json, os, sys
a, b = sys.argv[1], sys.argv[2]
def clean(x):  # timing keys and output paths are allowed to differ
    if isinstance(x, dict):
        return {k: clean(v) for k, v in x.items() if not k.endswith("seconds") and k != "lighting"}
    return [clean(v) for v in x] if isinstance(x, list) else x
n = 0
for f in sorted(glob.glob(f"{a}/items/scene*/*/*")):
    rel = os.path.relpath(f, a)
    if "/prepare/" in rel:  # the sphere trees' first build (local) against their read-back: not a result
        continue
    g = os.path.join(b, rel)
    if f.endswith(".json"):
        same = clean(json.load(open(f))) == clean(json.load(open(g)))
    elif f.endswith((".exr", ".png")):
        same = hashlib.sha256(open(f, "rb").read()).digest() == hashlib.sha256(open(g, "rb").read()).digest()
    else:
        continue
    assert same, f"{rel} differs"
    n += 1
keep = ["item", "kind", "status", "failed_stage", "psnr", "ssim", "env_angular_error_deg", "insert_psnr", "insert_ssim",
        "eval_psnr", "n_lobes"]
rows = lambda d: [[r[k] for k in keep] for r in csv.DictReader(open(f"{d}/summary/items.csv"))]
assert rows(a) == rows(b), (rows(a), rows(b))
print(f"ok: Slurm and local results identical: {n} files (JSON without timing keys, images byte for byte), items.csv")
EOF

# ---------------------------------------------------------------- 5. bad item removed
grep -v broken "$work/manifest.txt" > "$work/manifest2.txt"
MANIFEST=$work/manifest2.txt smk "$work/local3.log" out-local --cores 2 ||
  fail "without the bad item the run fails: $(tail -5 "$work/local3.log")"
[ "$(jobs_of "$work/local3.log" | tr '\n' ',')" = "summary," ] || fail "without the bad item: $(jobs_of "$work/local3.log")"
grep -q "^item,kind,failed_stage" "$work/out-local/summary/failed.csv" && [ "$(wc -l < "$work/out-local/summary/failed.csv")" = 1 ] ||
  fail "failed.csv still lists items"
MANIFEST=$work/manifest2.txt smk "$work/local4.log" out-local --cores 2 || fail "the run after that failed"
grep -q "Nothing to be done" "$work/local4.log" || fail "a run after a complete one did something: $(jobs_of "$work/local4.log")"
pass "bad item dropped: the summary alone was rewritten, then nothing to do"
echo "test_workflow: passed in $(secs "$t_start") s (local $t_local s, rerun $t_rerun s, Slurm $t_slurm s; $n_local jobs, $n_sub on Slurm)"
