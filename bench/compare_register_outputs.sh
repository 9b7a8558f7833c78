#!/bin/bash
# Byte comparison of `echoreg register --capture` and `echoreg calibrate` between two binaries
# (e.g. before and after a change of how their detection is executed), with each run's peak RSS
# and wall time, on simulated studies (`echoreg simulate`): register of the femur and the tibia
# from their first ultrasound sweep (from the truth's calibration and pose), and calibrate on the
# study's calibration shots.
#
#   bench/compare_register_outputs.sh OLD_ECHOREG NEW_ECHOREG OUT_DIR STUDY...
#
# Compares the result JSON, the .tfm, stdout, stderr and the exit code; prints one line per run
# ("same" or "DIFFERS: what", then "old: S s, KB kB; new: ...") and exits 1 when any run differs.
# Needs GNU time (/usr/bin/time) and python3.
set -u
old=$1 new=$2 out=$3
shift 3
status=0

run() {  # run SIDE BIN DIR NAME ARGS...
  local bin=$2 dir=$3 name=$4
  shift 4
  (cd "$dir" && /usr/bin/time -f "%e %M" -o "$name.time" "$bin" "$@" > "$name.out" 2> "$name.err"
    echo $? > "$name.rc")
}

for study in "$@"; do
  s=$(cd "$study" && pwd)
  tag=$(basename "$s")
  init=$(python3 -c "import json;m=json.load(open('$s/study.json'));print(' '.join(str(v) for v in m['calibration']['initial_beam_to_probe_mm']))")
  window=$(python3 -c "import json;m=json.load(open('$s/study.json'));print(' '.join(str(v) for v in m['calibration']['window_mm']))")
  for side in old new; do
    bin=$old
    [ "$side" = new ] && bin=$new
    dir="$out/$tag/$side"
    rm -rf "$dir"
    mkdir -p "$dir"
    for bone in femur tibia; do
      Bone=${bone^}
      run "$side" "$bin" "$dir" "register_$bone" register --model "$s/truth/$bone.vtp" --bone "$Bone" \
        --capture "$s/captures/${bone}_ultrasound.igs.mha" --calibration "$s/truth/BeamToProbe.json" \
        --initial "$s/truth/${Bone}ToCT.json" --out "register_$bone.json"
    done
    # shellcheck disable=SC2086
    run "$side" "$bin" "$dir" calibrate calibrate \
      --sphere-capture "$s/captures/calibration_sphere_stylus.igs.mha" \
      --stylus-tip-to-stylus "$s/truth/StylusTipToStylus.json" \
      --capture "$s/captures/calibration_shots.igs.mha" --sphere-radius 25.4 --stylus-tip-radius 1.5 \
      --initial $init --window-mm $window --fit-speed-of-sound --out calibrate.json
  done
  for name in register_femur register_tibia calibrate; do
    what=""
    for ext in json tfm out err rc; do
      cmp -s "$out/$tag/old/$name.$ext" "$out/$tag/new/$name.$ext" || what="$what $name.$ext"
    done
    read -r ot om < "$out/$tag/old/$name.time"
    read -r nt nm < "$out/$tag/new/$name.time"
    if [ -z "$what" ]; then
      echo "$tag $name: same (exit $(cat "$out/$tag/new/$name.rc")); old: $ot s, $om kB; new: $nt s, $nm kB"
    else
      echo "$tag $name: DIFFERS:$what; old: $ot s, $om kB; new: $nt s, $nm kB"
      status=1
    fi
  done
done
exit $status
