#!/usr/bin/env bash
# Five calibrations of one probe, like the dissertation's Tables 5.1 and 5.2, on a simulated
# study: pivot the stylus, calibrate every session with the assumed 1450 m/s and with the speed of
# sound fitted, and print the offsets, RMS and condition numbers beside the truth.
#
#   bench/calibration_sessions.sh [BUILD_DIR] [SEED]     (default build/release, 2008)
set -euo pipefail
build="${1:-build/release}"
seed="${2:-2008}"
echoreg="$build/cli/echoreg"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$echoreg" simulate --out "$work/study" --size small --seed "$seed" --calibrations 5 \
  --frames-per-bone 40 > /dev/null
"$echoreg" pivot --capture "$work/study/captures/stylus_pivot.igs.mha" --out "$work/tip.json" > /dev/null
read -r x y z < <(/usr/bin/python3 -c "import json,sys; print(*json.load(open(sys.argv[1]))['calibration']['initial_beam_to_probe_mm'])" "$work/study/study.json")
for k in 1 2 3 4 5; do
  suffix=""; [ "$k" -gt 1 ] && suffix="_$k"
  for fit in no yes; do
    extra=(); [ "$fit" = yes ] && extra=(--fit-speed-of-sound)
    "$echoreg" calibrate --sphere-capture "$work/study/captures/calibration_sphere_stylus$suffix.igs.mha" \
      --stylus-tip-to-stylus "$work/tip.json" --stylus-tip-radius 1.5 \
      --capture "$work/study/captures/calibration_shots$suffix.igs.mha" --sphere-radius 25.4 \
      --initial "$x" "$y" "$z" --window-mm 14 34 "${extra[@]}" --out "$work/c${k}_$fit.json" > /dev/null
  done
done
/usr/bin/python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
truth = json.load(open(f"{work}/study/truth/BeamToProbe.json"))["matrix"]
water = json.load(open(f"{work}/study/truth/calibration.json"))["water_speed_of_sound_mps"]
t = [truth[i][3] for i in range(3)]
print(f"truth: ({t[0]:.2f}, {t[1]:.2f}, {t[2]:.2f}) mm, bath {water:.1f} m/s, assumed 1450 m/s\n")
print("| session | speed | x | y | z | RMS (mm) | condition | speed (m/s) |")
print("|---|---|---|---|---|---|---|---|")
for fit in ("no", "yes"):
    xs = []
    for k in range(1, 6):
        c = json.load(open(f"{work}/c{k}_{fit}.json"))
        m = c["matrix"]
        xs.append([m[i][3] for i in range(3)])
        print(f"| {k} | {'fitted' if fit == 'yes' else '1450'} | {m[0][3]:.2f} | {m[1][3]:.2f} | {m[2][3]:.2f} | "
              f"{c['rms_mm']:.2f} | {c['condition_number']:.1f} | {c['speed_of_sound_mps']:.1f} |")
    spread = [max(v[i] for v in xs) - min(v[i] for v in xs) for i in range(3)]
    print(f"| spread | {'fitted' if fit == 'yes' else '1450'} | {spread[0]:.2f} | {spread[1]:.2f} | {spread[2]:.2f} | | | |")
print("| dissertation spread | 1450 | 5.36 | 1.12 | 0.25 | 0.55-0.91 | 6.2-14.2 | |")
PY
