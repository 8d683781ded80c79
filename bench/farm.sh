#!/usr/bin/env bash
# The farm's wall times against the serial study (docs/benchmarks.md, "Studies as tasks"):
# `weft tradeoff` of the fur study serially, with --farm local -j 2 (one setting per task, and
# --batch 13: two tasks), and through a one-node Slurm cluster started here
# (tests/farm/slurm_cluster.sh; --max-parallel 2 --wait). The runs of each round are
# interleaved so that other load on the machine falls on all of them alike; every farm run
# gets a fresh cache folder (nothing skipped), and its errors are checked against the serial
# run's. Prints each run and the medians.
#   bench/farm.sh [ROUNDS] [SIZE]     (default 3 rounds, 320x240)
set -euo pipefail
cd "$(dirname "$0")/.."
rounds="${1:-3}"
size="${2:-320x240}"
weft="$(pwd)/build/bin/weft"
work=$(mktemp -d /tmp/weft-farm-bench.XXXXXX)
trap 'bash tests/farm/slurm_cluster.sh stop "$work/cluster" >/dev/null 2>&1; rm -rf "$work"' EXIT
study=("$weft" tradeoff examples/fur/scenes/fur_spot.json --feature fur --size "$size" --frames 3)
slurm=1
if ! bash tests/farm/slurm_cluster.sh start "$work/cluster" >/dev/null 2>"$work/cluster.err"; then
  echo "no Slurm runs: $(tail -1 "$work/cluster.err")"
  slurm=0
fi
export SLURM_CONF="$work/cluster/slurm.conf"
echo "machine: $(nproc) cores, $(awk '/model name/ {sub(/^.*: /, ""); print; exit}' /proc/cpuinfo); load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "study: ${study[*]#"$weft"}"
declare -A times
run() {  # name command...
  local name="$1"; shift
  local start end
  start=$(date +%s.%N)
  "$@" >"$work/$name.log" 2>&1 || { echo "$name failed: $(tail -2 "$work/$name.log")"; exit 1; }
  end=$(date +%s.%N)
  local t; t=$(echo "$end - $start" | bc)
  times[$name]="${times[$name]:-} $t"
  printf '  %-14s %6.1f s\n' "$name" "$t"
}
check() {  # out folder: errors equal the serial run's
  python3 - "$work/serial/tradeoff.csv" "$1/tradeoff.csv" <<'PY'
import csv, sys
keys = ["rmse_linear", "relative_rmse", "psnr_db", "ssim", "max_diff", "pixels"]
e = lambda p: {r["setting"]: [r[k] for k in keys] for r in csv.DictReader(open(p))}
assert e(sys.argv[1]) == e(sys.argv[2]), "errors differ from the serial run: " + sys.argv[2]
PY
}
for r in $(seq "$rounds"); do
  echo "round $r"
  run serial "${study[@]}" -o "$work/serial"
  run local-j2 "${study[@]}" --farm local -j 2 --cache "$work/c-local-$r" -o "$work/local"
  check "$work/local"
  run local-j2-b13 "${study[@]}" --farm local -j 2 --batch 13 --cache "$work/c-local-b-$r" -o "$work/local-b"
  check "$work/local-b"
  if [ "$slurm" = 1 ]; then
    run slurm "${study[@]}" --farm slurm --max-parallel 2 --wait --cache "$work/c-slurm-$r" -o "$work/slurm"
    check "$work/slurm"
    run slurm-b13 "${study[@]}" --farm slurm --max-parallel 2 --batch 13 --wait --cache "$work/c-slurm-b-$r" -o "$work/slurm-b"
    check "$work/slurm-b"
  fi
done
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print (NR % 2 ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2)}'; }
echo "medians of $rounds (errors of every farm run equal to the serial run's):"
declare -A med
for name in serial local-j2 local-j2-b13 slurm slurm-b13; do
  [ -n "${times[$name]:-}" ] || continue
  med[$name]=$(echo "${times[$name]}" | median)
  printf '  %-14s %6.1f s  (runs:%s)\n' "$name" "${med[$name]}" "${times[$name]}"
done
ratio() { echo "scale=3; $1 / $2" | bc; }
echo "local -j 2 / serial: $(ratio "${med[local-j2]}" "${med[serial]}"); with --batch 13: $(ratio "${med[local-j2-b13]}" "${med[serial]}")"
if [ "$slurm" = 1 ]; then
  echo "slurm / local -j 2: $(ratio "${med[slurm]}" "${med[local-j2]}"); with --batch 13: $(ratio "${med[slurm-b13]}" "${med[local-j2-b13]}")"
fi
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
