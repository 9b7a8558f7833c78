#!/bin/bash
# A long session end to end through the two commands: `echoreg serve --repeat 0` of a femur sweep,
# re-timed to RATE A-lines a second, into `echoreg live` on loopback for SECONDS, with live's
# resident memory (VmRSS, VmHWM) and the recording's size every 10 s (docs/live.md, "Memory over a
# long session").
#
#   bench/serve_live_soak.sh ECHOREG STUDY OUT [SECONDS=600] [RATE=3000] [PORT=19617]
#
# STUDY is a simulated study (`echoreg simulate`; e.g. --size small --frames-per-bone 24000): its
# captures/femur_ultrasound.igs.mha and truth/{femur.vtp,BeamToProbe.json,FemurToCT.json}. OUT
# gets the sweep's samples (soak.raw) and a header soak.igs.mhd over them, its timestamps re-spaced
# to 1/RATE s. One `serve --repeat 0 --rate recorded` plays it again and again on one connection,
# each pass going on from the last as PLUS loops a saved capture, until `live --duration SECONDS`
# ends the session: one stream, one recording (OUT/session.igs.mha). Files in OUT: rss.log
# (seconds since live started, VmHWM and VmRSS in kB, the partial recording's bytes, the final
# .mha's bytes, load average), live.err / live.out / live.time (its /usr/bin/time -v),
# session.json, serve.out / serve.err. Disk: the recording (4 kB per A-line raw). Exits with
# live's exit code (1 also when its final registration did not converge).
set -u
bin=$1 study=$2 out=$3 seconds=${4:-600} rate=${5:-3000} port=${6:-19617}
sweep="$study/captures/femur_ultrasound.igs.mha"
mkdir -p "$out" || exit 1
rm -f "$out"/soak*.igs.mhd "$out"/session.* "$out"/serve* "$out"/rss.log

# The header, its timestamps re-spaced to RATE.
python3 - "$sweep" "$out" "$rate" <<'PY' || exit 1
import re, sys, zlib
src, out, rate = sys.argv[1], sys.argv[2], float(sys.argv[3])
data = open(src, 'rb').read()
head, body = data.split(b'ElementDataFile = LOCAL\n', 1)
head = head.decode()
raw = zlib.decompress(body) if re.search(r'^CompressedData = True$', head, re.M) else body
open(f'{out}/soak.raw', 'wb').write(raw)
head = re.sub(r'^CompressedData = True\n', 'CompressedData = False\n', head, flags=re.M)
head = re.sub(r'^CompressedDataSize = \d+\n', '', head, flags=re.M)
parts = re.split(r'(Seq_Frame\d+_Timestamp = )[^\n]+', head)
frames = (len(parts) - 1) // 2
text = [p if j % 2 == 0 else p + repr(round(1000.0 + (j // 2) / rate, 9))
        for j, p in enumerate(parts)]
with open(f'{out}/soak.igs.mhd', 'w') as f:
    f.write(''.join(text) + 'ElementDataFile = soak.raw\n')
print(f'a header of {frames} frames at {rate:g}/s ({frames / rate:.1f} s a pass)')
PY

"$bin" serve "$out/soak.igs.mhd" --port "$port" --wait 120 --rate recorded --repeat 0 \
  > "$out/serve.out" 2> "$out/serve.err" &
serve=$!
until grep -q "waiting for a client" "$out/serve.err" 2>/dev/null; do
  kill -0 "$serve" 2>/dev/null || { cat "$out/serve.err"; exit 1; }
  sleep 0.2
done
/usr/bin/time -v -o "$out/live.time" "$bin" live --connect "127.0.0.1:$port" \
  --model "$study/truth/femur.vtp" --bone Femur --calibration "$study/truth/BeamToProbe.json" \
  --initial "$study/truth/FemurToCT.json" --record "$out/session.igs.mha" \
  --out "$out/FemurToCT.json" --session-json "$out/session.json" \
  --duration "$seconds" > "$out/live.out" 2> "$out/live.err" &
timer=$!
sleep 0.5
live=$(pgrep -P "$timer" | head -1)
(
  t0=$(date +%s.%N)
  while [ -n "$live" ] && [ -e "/proc/$live/status" ]; do
    mem=$(grep -E 'VmHWM|VmRSS' "/proc/$live/status" | awk '{printf "%s %s ", $1, $2}')
    partial=$(du -sb "$out"/session.igs.partial.* 2>/dev/null | awk '{s += $1} END {print s + 0}')
    mha=$(stat -c %s "$out/session.igs.mha" 2>/dev/null || echo 0)
    echo "$(echo "$(date +%s.%N) - $t0" | bc) $mem partial_bytes $partial mha_bytes $mha load $(cut -d' ' -f1 /proc/loadavg)"
    sleep 10
  done
) > "$out/rss.log" &
monitor=$!

wait "$timer"
status=$?
wait "$monitor"
wait "$serve"
serve_status=$?
echo "live exit $status; serve exit $serve_status: $(cat "$out/serve.out")"
echo "$out/rss.log:"
cat "$out/rss.log"
tail -n 3 "$out/live.err"
exit $status
