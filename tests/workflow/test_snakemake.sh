#!/bin/sh
# workflow/Snakefile run by Snakemake on two copies of the fixture study (glove and gel standoff)
# and a sweep of two speeds of sound over the first, with --cores 2: the comparison of the four
# studies, the sweep's table the same bytes as `echoreg study sweep` run by hand, a second run
# that has nothing to do, and a lost row rebuilt to the same bytes. Skips (exit 77) without
# snakemake (scripts/install-deps --workflow) or the fixture study.
# Usage: test_snakemake.sh ECHOREG SNAKEFILE FIXTURE_STUDY WORKDIR
set -eu
echoreg=$1 snakefile=$2 fixture=$3 work=$4
if ! command -v snakemake >/dev/null 2>&1; then
  echo "snakemake is not installed (scripts/install-deps --workflow): skipping the workflow test"
  exit 77
fi
if [ ! -f "$fixture/study.json" ]; then
  echo "the fixture study $fixture is absent (ctest -R simulate_fixture_study): skipping"
  exit 77
fi
fail() { echo "FAIL: $*" >&2; exit 1; }

rm -rf "$work" && mkdir -p "$work" && cd "$work"
for study in glove gel; do
  cp -r "$fixture" "$study" && rm -rf "$study/results"
done
python3 - <<'PY'
import json
m = json.load(open("gel/study.json"))
assert m["generator"]["standoff"] == "glove", m["generator"]
m["generator"]["standoff"] = "gel"
json.dump(m, open("gel/study.json", "w"), indent=2)
PY
cat > sweep.json <<'JSON'
{"study": "glove", "given_models": true, "parameters": {"detect.speed-of-sound": [1500, 1540]}}
JSON
run() {
  snakemake -s "$snakefile" --cores 2 --config echoreg="$echoreg" studies=glove,gel \
    given_models=true sweep=sweep.json group_by=generator.standoff > "$1" 2>&1 ||
    { cat "$1"; fail "snakemake exited $?"; }
}
start=$(date +%s)
run first.log
echo "workflow: first run $(( $(date +%s) - start )) s"
for f in compare/report.html compare/report.md compare/results.json sweep/results.jsonl \
         glove/results/results.json gel/results/results.json; do
  [ -s "$f" ] || fail "$f was not written"
done
python3 - <<'PY' || fail "the comparison or the table is not what the workflow was asked for"
import json
merged = json.load(open("compare/results.json"))
names = [s["name"] for s in merged["studies"]]
groups = [s["group"] for s in merged["studies"]]
assert len(merged["studies"]) == 4, names
assert groups == ["glove", "gel", "glove", "glove"], groups
assert merged["between_groups"]["femur"]["anova"]["df_between"] == 1, merged["between_groups"]
rows = [json.loads(line) for line in open("sweep/results.jsonl")]
assert [r["parameters"]["detect.speed-of-sound"] for r in rows] == [1500, 1540], rows
for r in rows:
    results = json.load(open("sweep/" + r["study"] + "/results/results.json"))
    assert r["registrations"] == results["registrations"], r["point"]
PY
grep -q "study compare" first.log || fail "the log does not show the comparison"

# The same bytes as the sweep run by hand.
"$echoreg" study sweep sweep.json --out byhand > byhand.log 2>&1 || { cat byhand.log; fail "the sweep by hand failed"; }
cmp sweep/results.jsonl byhand/results.jsonl || fail "the workflow's table differs from the sweep by hand"
cp sweep/results.jsonl table.jsonl

# A second run has nothing to do.
run second.log
grep -q "Nothing to be done" second.log || { cat second.log; fail "the second run did something"; }

# A run killed while one point ran: its row, the table and the comparison are not there yet. The
# restart runs that point alone (not the studies, not the other point), then the table and the
# comparison; same bytes.
first_row=$(ls sweep/rows | head -n 1)
rm -r "sweep/rows/$first_row" sweep/results.jsonl compare
run third.log
[ "$(grep -c '^rule sweep_point' third.log)" = 1 ] || { cat third.log; fail "not exactly the lost point ran again"; }
! grep -q '^rule study_run' third.log || { cat third.log; fail "a finished study ran again"; }
cmp sweep/results.jsonl table.jsonl || fail "the rebuilt table differs"
[ -s compare/report.html ] || fail "the comparison was not rebuilt"
echo "workflow: 2 studies and a 2-point sweep compared; same bytes as by hand; resumed"
