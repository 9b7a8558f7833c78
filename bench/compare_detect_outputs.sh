#!/bin/sh
# Byte comparison of `echoreg detect` between two binaries (e.g. before and after a change of how
# detection is executed): the CSV, stdout (--json and plain), stderr and the exit code, for every
# capture given and a few sets of flags.
#
#   bench/compare_detect_outputs.sh OLD_ECHOREG NEW_ECHOREG OUT_DIR CAPTURE...
#
# Captures with ProbeToTracker are also run with --pose (and FemurToTracker / TibiaToTracker as
# --reference when present). Prints one line per run ("same" or "DIFFERS: what") and exits 1 when
# any run differs.
set -u
old=$1 new=$2 out=$3
shift 3
mkdir -p "$out"
status=0
run=0

compare() {  # compare NAME ARGS...
  name=$1
  shift
  run=$((run + 1))
  for side in old new; do
    bin=$old
    [ "$side" = new ] && bin=$new
    "$bin" detect "$@" --out "$out/$name.$side.csv" > "$out/$name.$side.out" 2> "$out/$name.$side.err"
    echo $? > "$out/$name.$side.rc"
    sed "s#$out/$name.$side.csv#OUT.csv#g" "$out/$name.$side.out" > "$out/$name.$side.out.n"
    sed "s#$out/$name.$side.csv#OUT.csv#g" "$out/$name.$side.err" > "$out/$name.$side.err.n"
  done
  what=""
  for part in csv out.n err.n rc; do
    if [ -e "$out/$name.old.$part" ] || [ -e "$out/$name.new.$part" ]; then
      cmp -s "$out/$name.old.$part" "$out/$name.new.$part" || what="$what $part"
    fi
  done
  if [ -z "$what" ]; then
    lines=0
    [ -f "$out/$name.new.csv" ] && lines=$(wc -l < "$out/$name.new.csv")
    echo "same     $name (exit $(cat "$out/$name.new.rc"), $lines lines)"
  else
    echo "DIFFERS  $name:$what"
    status=1
  fi
}

for capture in "$@"; do
  base=$(basename "$capture" | sed 's/\..*//')
  compare "$base-default" "$capture" --json
  compare "$base-plain" "$capture"
  for preset in mozes2008 calibration shadow; do
    compare "$base-$preset" "$capture" --preset "$preset" --json
  done
  if grep -aq "ProbeToTrackerTransform " "$capture" 2> /dev/null; then
    compare "$base-pose" "$capture" --pose ProbeToTracker --json
    for bone in Femur Tibia; do
      if grep -aq "${bone}ToTrackerTransform " "$capture"; then
        compare "$base-pose-$bone" "$capture" --pose ProbeToTracker --reference "${bone}ToTracker" --json
        compare "$base-pose-$bone-run" "$capture" --pose ProbeToTracker \
          --reference "${bone}ToTracker" --temporal run --history 3 --min-spread-mm 0.5
      fi
    done
  fi
done
echo "$run runs compared"
exit $status
