#!/usr/bin/env bash
# test_farm_slurm WEFT slurm_cluster.sh: a tiny fur study through a one-node Slurm cluster
# started here (munged with a fresh key, slurmctld + slurmd, no cgroups) and stopped at the
# end. One array task is requeued while it runs (as a pre-emption does) and one is cancelled
# (scancel) and requeued (scontrol requeue); every task's output must be there, uncorrupted,
# and the merged errors must equal `--farm local`'s byte for byte. Bad input (an unknown
# partition) is refused before anything is submitted. Exit 77 (ctest: skipped) with one line
# saying why only when the daemons cannot start on this machine.
set -uo pipefail
weft="${1:?usage: test_farm_slurm.sh WEFT slurm_cluster.sh}"
cluster="${2:?usage: test_farm_slurm.sh WEFT slurm_cluster.sh}"
source_dir="${WEFT_SOURCE_DIR:?WEFT_SOURCE_DIR must name the source tree}"
work=$(mktemp -d /tmp/weft-slurm-test.XXXXXX)
fail() { echo "test_farm_slurm: FAILED: $*" >&2; exit 1; }
cleanup() { bash "$cluster" stop "$work/cluster" >/dev/null 2>&1; [ "${keep:-0}" = 1 ] || rm -rf "$work"; }
trap cleanup EXIT

if ! out=$(bash "$cluster" start "$work/cluster" 2>&1); then
  echo "test_farm_slurm: skipped: ${out##*$'\n'}"
  exit 77
fi
export SLURM_CONF="$work/cluster/slurm.conf"
echo "cluster up: $(sinfo -h -o '%P %t %c CPUs' | head -1)"

cat >"$work/fur.json" <<JSON
{"version": 1, "output": {"width": 32, "height": 24},
 "camera": {"position": [0, 0.4, 2], "target": [0, 0, 0]},
 "lights": [{"type": "directional", "direction": [-0.5, -1, -0.4], "intensity": 2}],
 "environment": {"color": [0.2, 0.2, 0.2]},
 "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 16}},
 "materials": {"fur": {"type": "fur", "photo": "$source_dir/examples/fur/synthetic_fur.png", "layers": 4, "wrap": "repeat"}},
 "objects": [{"name": "ball", "mesh": "ball", "material": "fur"}]}
JSON
study=("$weft" tradeoff "$work/fur.json" --feature fur --frames 2 --values layers=1,2,4,8 --values fin_threshold=0.5)

# bad input: an unknown partition is named, nothing is submitted
if bad=$("${study[@]}" --farm slurm --partition nosuch --cache "$work/cache" -o "$work/slurm" 2>&1); then fail "--partition nosuch was accepted: $bad"; fi
echo "$bad" | grep -q "nosuch" || fail "the unknown partition is not named: $bad"
echo "$bad" | grep -q "test" || fail "the cluster's partitions are not listed: $bad"
[ -z "$(squeue -h)" ] || fail "a job was submitted for a bad partition"

# the study through the cluster
submitted=$("${study[@]}" --farm slurm --max-parallel 2 --cache "$work/cache" -o "$work/slurm" 2>&1) || fail "submit: $submitted"
echo "$submitted"
array=$(echo "$submitted" | sed -n 's/^submitted array job \([0-9]*\) .*/\1/p')
[ -n "$array" ] || fail "no array job id in: $submitted"
tasks=$(echo "$submitted" | sed -n 's/^submitted array job [0-9]* (\([0-9]*\) tasks).*/\1/p')
[ "$tasks" -ge 6 ] || fail "expected at least 6 tasks, got '$tasks'"

# pre-empt the first task seen running (scontrol requeue), then cancel another running one
# and requeue it (a pending array task cannot be: scancel drops it from the array)
running_task() {  # the index of a running array task other than $1, or nothing after ~20 s
  local t
  for _ in $(seq 400); do
    t=$(squeue -h -r -j "$array" -t R -o '%K' | grep -vx "${1:-none}" | head -1)
    [ -n "$t" ] && { echo "$t"; return; }
    sleep 0.05
  done
}
running=$(running_task)
[ -n "$running" ] || fail "no array task ever ran"
scontrol requeue "${array}_${running}" || fail "scontrol requeue ${array}_${running} refused"
echo "requeued running task $running"
# (a task may finish between being seen running and the scancel: then take another)
state=""
for attempt in 1 2 3 4 5; do
  cancelled=$(running_task "$running")
  [ -n "$cancelled" ] || fail "no second array task ran"
  scancel "${array}_${cancelled}" || fail "scancel ${array}_${cancelled} refused"
  for _ in $(seq 100); do
    state=$(scontrol show job "${array}_${cancelled}" -o 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
    [ "$state" = CANCELLED ] || [ "$state" = COMPLETED ] && break
    sleep 0.1
  done
  [ "$state" = CANCELLED ] && break
  echo "task $cancelled ended $state before the scancel reached it; trying another"
done
[ "$state" = CANCELLED ] || fail "task $cancelled is '$state' after scancel"
scontrol requeue "${array}_${cancelled}" || fail "scontrol requeue of the cancelled task $cancelled refused"
# a requeued job waits out the credential lifetime before it may start again; start them now
for t in "$running" "$cancelled"; do scontrol update JobId="${array}_${t}" StartTime=now >/dev/null 2>&1 || true; done
echo "cancelled and requeued task $cancelled"

"$weft" farm status "$array" --cache "$work/cache" || fail "farm status"
waited=$("$weft" farm wait "$array" --cache "$work/cache" --timeout 240 2>&1) || { keep=1; fail "farm wait: $waited (kept $work)"; }
echo "$waited"
[ -f "$work/slurm/tradeoff.csv" ] || fail "the reduce job wrote no tradeoff.csv"
"$weft" farm collect "$array" --cache "$work/cache" >/dev/null 2>&1 || fail "farm collect"

# nothing lost, nothing half-written
list=$(ls "$work"/cache/farm/*.tasks.json | head -1)
leftover=$(find "$work/cache/tradeoff" -name '*.tmp' | wc -l)
[ "$leftover" -eq 0 ] || fail "$leftover temporary files left in the cache"
python3 - "$list" "$work/cache" "$running" "$cancelled" <<'PY' || fail "task outputs"
import json, sys, os
tasks = json.load(open(sys.argv[1]))["tasks"]
for t in tasks:
    for o in t["outputs"]:
        p = os.path.join(sys.argv[2], o)
        assert os.path.isfile(p), "missing " + p
        if p.endswith(".json"):
            assert json.load(open(p))["id"] == t["id"], "damaged " + p
        else:
            assert open(p, "rb").read(8) == b"\x89PNG\r\n\x1a\n", "damaged " + p
starts = []
for index in sys.argv[3:5]:
    log = open(os.path.join(sys.argv[2], "logs", tasks[int(index)]["id"] + ".log")).read()
    starts.append(log.count("[weft farm] task "))
# each was stopped while running and ran again (or found its output done and skipped)
assert all(n >= 1 for n in starts), f"a requeued task never started: {starts}"
print(f"{len(tasks)} tasks, every output present and whole; the requeued and the cancelled task started {starts} times")
PY

# the same study with --farm local: errors byte for byte
"${study[@]}" --farm local -j 2 --cache "$work/local-cache" -o "$work/local" >/dev/null 2>&1 || fail "--farm local"
python3 - "$work/slurm/tradeoff.csv" "$work/local/tradeoff.csv" <<'PY' || fail "merged errors differ from --farm local"
import csv, sys
def errors(path):
    rows = list(csv.DictReader(open(path)))
    keys = ["rmse_linear", "relative_rmse", "psnr_db", "ssim", "max_diff", "pixels"]
    assert all(r["cost_ratio"] not in ("", "nan") for r in rows), "a row without a cost ratio in " + path
    return {r["setting"]: [r[k] for k in keys] for r in rows}
a, b = errors(sys.argv[1]), errors(sys.argv[2])
assert a == b, f"{a} != {b}"
print(f"{len(a)} settings: errors identical to --farm local, costs as ratios")
PY
# several settings per array task, submitted and waited for in one command (--wait)
"${study[@]}" --farm slurm --batch 6 --wait --cache "$work/cache-batch" -o "$work/slurm-batch" >"$work/batch.log" 2>&1 ||
  fail "--farm slurm --batch 6 --wait: $(tail -3 "$work/batch.log")"
grep -q "submitted array job [0-9]* (3 tasks)" "$work/batch.log" || fail "expected 3 tasks of 6 settings: $(head -3 "$work/batch.log")"
python3 - "$work/slurm-batch/tradeoff.csv" "$work/local/tradeoff.csv" <<'PY' || fail "batched errors differ from --farm local"
import csv, sys
keys = ["rmse_linear", "relative_rmse", "psnr_db", "ssim", "max_diff", "pixels"]
e = lambda p: {r["setting"]: [r[k] for k in keys] for r in csv.DictReader(open(p))}
assert e(sys.argv[1]) == e(sys.argv[2])
print("--batch 6 --wait: errors identical")
PY
# a two-material bake (synthetic plain and twill BTFs) as a job array, placed by the reduce job
cat >"$work/bakes.json" <<'JSON'
{"version": 1, "bakes": [
  {"bake": "btf", "args": ["--synthetic", "4x4", "--weave", "plain", "--clusters", "4", "--epochs", "1", "--directions", "64"], "output": "lib/plain.wbtf"},
  {"bake": "btf", "args": ["--synthetic", "4x4", "--weave", "twill", "--clusters", "4", "--epochs", "1", "--directions", "64"], "output": "lib/twill.wbtf"}]}
JSON
"$weft" farm run "$work/bakes.json" --farm slurm --wait --cache "$work/cache-bake" >"$work/bake.log" 2>&1 || fail "bake array: $(tail -3 "$work/bake.log")"
grep -q "submitted array job [0-9]* (2 tasks)" "$work/bake.log" || fail "expected 2 bake tasks: $(head -3 "$work/bake.log")"
for m in plain twill; do
  [ "$(head -c 8 "$work/lib/$m.wbtf" | tr -d '\0')" != "" ] || fail "lib/$m.wbtf was not placed"
done
cmp -s "$work/lib/plain.wbtf" "$work/lib/twill.wbtf" && fail "the two materials baked the same file"
echo "two-material bake: both .wbtf placed by the reduce job"
echo "test_farm_slurm: passed"
