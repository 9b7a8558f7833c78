#!/usr/bin/env bash
# The dissertation's registration findings (Mozes 2008, sections 5.2, 5.4, 6.2, 6.3.5) on
# simulated specimens, each bone registered once per sweep (--registrations, 3 here; the
# dissertation did 5) and compared with the truth by `echoreg evaluate`:
#   (a) phantom in a water bath: points detected at 1450 m/s (the capture's assumption), at
#       1540 m/s, and at the bath's speed fitted by the calibration; the mean signed distance of
#       the points to the surface under the true transform (Eq. 4.6; > 0 floats off) and after
#       registration, and the registration errors;
#   (b) femur swept over the anterior distal femur and the epicondyles vs the epicondyles only
#       (specimen #3's technique);
#   (c) tibia registered to the tibia alone vs to the tibia and fibula (specimen #3's model), the
#       same points: the rotation about the long axis (rz).
# Every registration starts from the two landmarks of its bone touched with the stylus
# (epicondyles, malleoli; the rotation about their line searched) and uses the robust method.
# Translations are the displacement of the true knee centre (evaluate --centre).
#
#   bench/registration_findings.sh [BUILD_DIR] [WORK_DIR] [SEED]
#       (default build/release, BUILD_DIR/findings, 2008; 2 min 12 s on 2 cores from scratch)
# Prints Markdown tables (also written to WORK_DIR/findings.md).
set -euo pipefail
build="${1:-build/release}"
work="${2:-$build/findings}"
seed="${3:-2008}"
registrations=3
echoreg="$build/cli/echoreg"
py=/usr/bin/python3   # Debian's, with python3-vtk9 for the signed distances
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$work"

# simulate NAME FLAGS...: a small study, once.
simulate() {
  local name="$1"; shift
  if [ ! -f "$work/$name/study.json" ]; then
    rm -rf "${work:?}/$name"
    "$echoreg" simulate --out "$work/$name" --size small --seed "$seed" \
      --registrations "$registrations" "$@" > /dev/null
  fi
}

# prepare NAME: the stylus tip by pivoting and the transducer calibrated on the sphere (speed of
# sound fitted), as `make demo` does.
prepare() {
  local s="$work/$1"
  mkdir -p "$s/results"
  "$echoreg" pivot --capture "$s/captures/stylus_pivot.igs.mha" --out "$s/results/stylus_tip.json" > /dev/null
  read -r x y z < <($py -c "import json,sys; print(*json.load(open(sys.argv[1]))['calibration']['initial_beam_to_probe_mm'])" "$s/study.json")
  "$echoreg" calibrate --sphere-capture "$s/captures/calibration_sphere_stylus.igs.mha" \
    --stylus-tip-to-stylus "$s/results/stylus_tip.json" --stylus-tip-radius 1.5 \
    --capture "$s/captures/calibration_shots.igs.mha" --sphere-radius 25.4 \
    --initial "$x" "$y" "$z" --window-mm 14 34 --fit-speed-of-sound --out "$s/results/calibration.json" > /dev/null
}

sweep() {  # sweep BONE K -> capture file name
  if [ "$2" -eq 1 ]; then echo "$1_ultrasound.igs.mha"; else echo "$1_ultrasound_$2.igs.mha"; fi
}

labels() {  # the two landmarks of a bone, as the simulated studies touch them
  if [ "$1" = femur ]; then echo medial_epicondyle,lateral_epicondyle; else echo medial_malleolus,lateral_malleolus; fi
}

dwells() {  # their dwells in the landmark capture (touch order: epicondyles, then malleoli)
  if [ "$1" = femur ]; then echo 0 1; else echo 2 3; fi
}

Bone() { if [ "$1" = femur ]; then echo Femur; else echo Tibia; fi; }

# register STUDY BONE MODEL OUT ARGS...: one registration started from the bone's landmarks
# (their dwells named: the skin over the malleoli is far enough from the CT's bony landmarks that
# register's own choice by distance refuses them).
# A registration that does not converge is kept (exit 1 is reported, not fatal).
register() {
  local s="$work/$1" bone="$2" model="$3" out="$4"; shift 4
  local pair
  read -r -a pair < <(dwells "$bone")
  "$echoreg" register --model "$model" --bone "$(Bone "$bone")" \
    --landmarks-ct "$s/ct/landmarks.mrk.json" --landmarks-capture "$s/captures/landmarks.igs.mha" \
    --stylus-tip-to-stylus "$s/results/stylus_tip.json" --landmark-labels "$(labels "$bone")" \
    --landmark-dwells "${pair[@]}" --out "$out" "$@" > /dev/null 2>> "$work/register.log" || echo "not converged: $out" >> "$work/register.log"
}

# evaluate STUDY BONE CSV ESTIMATES...: errors against the truth, at the knee centre.
evaluate() {
  local s="$work/$1" bone="$2" csv="$3"; shift 3
  local knee
  knee=$($py -c "import json,sys; print(*json.load(open(sys.argv[1]))['knee_centre_ct'])" "$s/truth/points.json")
  local args=()
  for e in "$@"; do if [ -f "$e" ]; then args+=(--estimate "$e"); fi; done
  # shellcheck disable=SC2086
  "$echoreg" evaluate --reference "$s/truth/$(Bone "$bone")ToCT.json" "${args[@]}" \
    --targets "$s/truth/landmarks.mrk.json" --centre $knee --out "$csv" > /dev/null
}

: > "$work/register.log"
simulate phantom --preset phantom
simulate cad_all
simulate cad_epicondyles --femur-regions epicondyles
simulate cad_fibula --fibula-in-tibia
for s in phantom cad_all cad_epicondyles; do prepare "$s"; done

# (a) Phantom: detection at three speeds (the phantom's single echo: --peaks max, every frame
# judged alone), registration on the detected points.
fitted=$($py -c "import json,sys; print(round(json.load(open(sys.argv[1]))['speed_of_sound_mps'], 1))" "$work/phantom/results/calibration.json")
s="$work/phantom"
for speed in 1450 1540 "$fitted"; do
  for bone in femur tibia; do
    outs=()
    for k in $(seq 1 "$registrations"); do
      base="$s/results/${bone}_${speed}_$k"
      "$echoreg" detect "$s/captures/$(sweep "$bone" "$k")" --pose ProbeToTracker \
        --reference "$(Bone "$bone")ToTracker" --beam-to-probe "$s/results/calibration.json" \
        --peaks max --history 1 --speed-of-sound "$speed" --out "$base.csv" > /dev/null
      register phantom "$bone" "$s/truth/$bone.vtp" "$base.json" --points "$base.csv"
      outs+=("$base.json")
    done
    evaluate phantom "$bone" "$s/results/errors_${bone}_${speed}.csv" "${outs[@]}"
  done
done

# (b) Femur: all regions vs the epicondyles only (the cadaver's own chain: default preset,
# 1540 m/s from the capture's header), from two starts: the two epicondyles (register searches
# the rotation about their line), and the four landmarks of the straight leg registered in the
# femur marker's frame by `echoreg landmarks` (the malleoli 40 cm away fix that rotation).
for study in cad_all cad_epicondyles; do
  s="$work/$study"
  "$echoreg" landmarks --capture "$s/captures/landmarks.igs.mha" \
    --stylus-tip-to-stylus "$s/results/stylus_tip.json" --reference FemurToTracker \
    --landmarks "$s/ct/landmarks.mrk.json" \
    --labels medial_epicondyle,lateral_epicondyle,medial_malleolus,lateral_malleolus \
    --invert --out "$s/results/femur_leg_landmarks.json" > /dev/null
  outs=(); outs4=()
  for k in $(seq 1 "$registrations"); do
    register "$study" femur "$s/truth/femur.vtp" "$s/results/femur_$k.json" \
      --capture "$s/captures/$(sweep femur "$k")" --calibration "$s/results/calibration.json"
    "$echoreg" register --model "$s/truth/femur.vtp" --bone Femur \
      --capture "$s/captures/$(sweep femur "$k")" --calibration "$s/results/calibration.json" \
      --initial "$s/results/femur_leg_landmarks.json" --out "$s/results/femur_leg_$k.json" \
      > /dev/null 2>> "$work/register.log" || echo "not converged: $s/results/femur_leg_$k.json" >> "$work/register.log"
    outs+=("$s/results/femur_$k.json"); outs4+=("$s/results/femur_leg_$k.json")
  done
  evaluate "$study" femur "$s/results/errors_femur.csv" "${outs[@]}"
  evaluate "$study" femur "$s/results/errors_femur_leg.csv" "$s/results/femur_leg_landmarks.json" "${outs4[@]}"
done

# (c) Tibia: the same sweeps registered to the tibia alone and to the tibia with the fibula.
s="$work/cad_all"
for model in tibia_only tibia_fibula; do
  mesh="$s/truth/tibia.vtp"
  [ "$model" = tibia_fibula ] && mesh="$work/cad_fibula/truth/tibia.vtp"
  outs=()
  for k in $(seq 1 "$registrations"); do
    register cad_all tibia "$mesh" "$s/results/${model}_$k.json" \
      --capture "$s/captures/$(sweep tibia "$k")" --calibration "$s/results/calibration.json"
    outs+=("$s/results/${model}_$k.json")
  done
  evaluate cad_all tibia "$s/results/errors_${model}.csv" "${outs[@]}"
done

$py "$here/registration_findings.py" "$work" "$registrations" "$fitted" | tee "$work/findings.md"
