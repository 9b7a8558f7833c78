#!/bin/sh
# workflow/Snakefile through Snakemake's Slurm executor (`--slurm`) on a Slurm cluster: the grid
# of test_snakemake.sh (two copies of the fixture study, glove and gel, and a sweep of two speeds
# of sound over the first), run once with --cores 2 and once with --slurm in the same folder; the
# same results (the sweep's table byte for byte; everything else apart from the steps' wall-clock
# times); every job a COMPLETED Slurm job; a second --slurm run has nothing to do.
# The cluster: the one SLURM_CONF names, when it is set (it must answer with an idle node);
# otherwise a private single-node cluster in WORKDIR/cluster, started for this test and stopped
# after it by scripts/slurm-single-node run (Debian's slurm-wlm and munge, as root, loopback only).
# Skips (exit 77) with the reason without snakemake (scripts/install-deps --workflow), without the
# fixture study, when SLURM_CONF's cluster does not answer, or when this machine cannot host the
# private cluster (Slurm not installed: scripts/install-deps --slurm; not root; a host name that
# does not resolve to loopback).
# Usage: test_slurm.sh ECHOREG SNAKEFILE FIXTURE_STUDY WORKDIR SLURM_SINGLE_NODE
set -eu
echoreg=$1 snakefile=$2 fixture=$3 work=$4 single_node=$5
if ! command -v snakemake >/dev/null 2>&1; then
  echo "snakemake is not installed (scripts/install-deps --workflow): skipping the Slurm test"
  exit 77
fi
if [ ! -f "$fixture/study.json" ]; then
  echo "the fixture study $fixture is absent (ctest -R simulate_fixture_study): skipping"
  exit 77
fi
if [ -z "${SLURM_CONF:-}" ]; then
  # A cluster of the test's own; a cluster an earlier, killed run left in its folder is stopped.
  [ ! -d "$work/cluster" ] || bash "$single_node" stop "$work/cluster"
  rm -rf "$work" && mkdir -p "$work"
  start=$(date +%s)
  status=0
  bash "$single_node" run "$work/cluster" sh "$0" "$@" || status=$?
  if [ "$status" -eq 3 ]; then
    echo "this machine cannot host the single-node Slurm cluster (the reason above): skipping"
    exit 77
  fi
  echo "slurm test: with its private cluster (start, test, stop) in $(( $(date +%s) - start )) s"
  exit "$status"
fi
if ! command -v sinfo >/dev/null 2>&1 || ! sinfo -h -o %t 2>/dev/null | grep -Eq '^(idle|mix)'; then
  echo "the Slurm cluster of SLURM_CONF=$SLURM_CONF does not answer with an idle node: skipping" \
    "the Slurm test (unset SLURM_CONF to let the test start a private single-node one)"
  exit 77
fi
fail() { echo "FAIL: $*" >&2; exit 1; }
# Snakemake's Slurm executor reads USER (to guess an account).
USER=${USER:-$(id -un)}
export USER
partition=$(sinfo -h -o %P | sed -n 's/\*$//p' | head -n 1)
[ -n "$partition" ] || partition=$(sinfo -h -o %P | head -n 1)

# Both runs in the same folder ($work/run; the first one moved to $work/cores after it), so that
# the comparison does not depend on where the studies lie (the studies' own results hold no
# absolute paths; this keeps the check independent of that).
prepare() {
  rm -rf "$work/run" && mkdir -p "$work/run" && cd "$work/run"
  for study in glove gel; do
    cp -r "$fixture" "$study" && rm -rf "$study/results"
  done
  python3 -c '
import json
m = json.load(open("gel/study.json"))
m["generator"]["standoff"] = "gel"
json.dump(m, open("gel/study.json", "w"), indent=2)'
  echo '{"study": "glove", "given_models": true, "parameters": {"detect.speed-of-sound": [1500, 1540]}}' > sweep.json
}
config="echoreg=$echoreg studies=glove,gel given_models=true sweep=sweep.json group_by=generator.standoff"

rm -rf "$work/run" "$work/cores" && mkdir -p "$work"
prepare
start=$(date +%s)
# shellcheck disable=SC2086
snakemake -s "$snakefile" --cores 2 --config $config > run.log 2>&1 || { cat run.log; fail "snakemake --cores 2 failed"; }
echo "slurm test: --cores 2 in $(( $(date +%s) - start )) s"
cd "$work" && mv run cores

prepare
slurm() {
  # One status check a second (Snakemake's default with --slurm: one per 33 s).
  # shellcheck disable=SC2086
  snakemake -s "$snakefile" --slurm --jobs 2 --max-status-checks-per-second 1 \
    --default-resources slurm_partition="$partition" mem_mb=1000 runtime=30 \
    --config $config > "$1" 2>&1 || { cat "$1"; fail "snakemake --slurm failed"; }
}
start=$(date +%s)
slurm first.log
echo "slurm test: --slurm in $(( $(date +%s) - start )) s"
# Every job went through Slurm: one sbatch each (2 studies, 2 points, the table, the comparison),
# each known to the controller as COMPLETED, or, once the controller has forgotten it (MinJobAge;
# sacct needs an accounting database the single-node cluster has not), with its Slurm log.
ids=$(sed -n 's/.*has been submitted with SLURM jobid \([0-9]*\) .*/\1/p' first.log)
[ "$(echo "$ids" | wc -w)" = 6 ] || { cat first.log; fail "expected 6 jobs submitted to Slurm, got: $ids"; }
for id in $ids; do
  if state=$(scontrol show job "$id" 2>/dev/null); then
    echo "$state" | grep -q 'JobState=COMPLETED' || fail "Slurm job $id: $(echo "$state" | grep -o 'JobState=[A-Z_]*')"
  else
    ls .snakemake/slurm_logs/*/"$id".log >/dev/null 2>&1 || fail "Slurm job $id left no log"
  fi
done
echo "slurm test: Slurm jobs $(echo "$ids" | tr '\n' ' ')COMPLETED"
cmp sweep/results.jsonl ../cores/sweep/results.jsonl || fail "the sweep's table differs between --slurm and --cores 2"
python3 - "$work/cores" <<'PY' || fail "the results differ between --slurm and --cores 2 (beyond wall-clock times)"
import json, os, sys
def timeless(v):
    if isinstance(v, dict):
        return {k: timeless(x) for k, x in v.items() if k != "seconds"}
    if isinstance(v, list):
        return [timeless(x) for x in v]
    return v
files = ["compare/results.json", "glove/results/results.json", "gel/results/results.json"]
files += ["sweep/" + json.loads(l)["study"] + "/results/results.json" for l in open("sweep/results.jsonl")]
for f in files:
    a, b = (timeless(json.load(open(os.path.join(d, f)))) for d in (".", sys.argv[1]))
    assert a == b, f
# Every other file the studies and points wrote (CSV tables, PNG figures, transforms), byte for
# byte; the reports and the step state carry the wall-clock times.
count = 0
for top in ("glove/results", "gel/results", "sweep"):
    for root, _, names in os.walk(top):
        for n in names:
            f = os.path.join(root, n)
            if n.endswith((".json", ".md", ".html")) or n.startswith("."):
                continue
            with open(f, "rb") as x, open(os.path.join(sys.argv[1], f), "rb") as y:
                assert x.read() == y.read(), f
            count += 1
assert count > 0
print(f"slurm test: {len(files)} results.json the same apart from times, {count} other files the same bytes")
PY
slurm second.log
grep -q "Nothing to be done" second.log || { cat second.log; fail "the second --slurm run did something"; }
! grep -q 'has been submitted' second.log || { cat second.log; fail "the second run submitted a job"; }
echo "slurm test: 6 Slurm jobs; the same results as --cores 2; a second run does nothing"
