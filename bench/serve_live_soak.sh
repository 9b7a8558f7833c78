#!/bin/bash
# A long session end to end through the two commands: `echoreg serve` of a femur sweep, re-timed to
# RATE A-lines a second, into `echoreg live` on loopback for SECONDS, with live's resident memory
# (VmRSS, VmHWM) and the recording's size every 10 s (docs/live.md, "Memory over a long session").
#
#   bench/serve_live_soak.sh ECHOREG STUDY OUT [SECONDS=600] [RATE=3000] [PORT=19617]
#
# STUDY is a simulated study (`echoreg simulate`; e.g. --size small --frames-per-bone 24000): its
# captures/femur_ultrasound.igs.mha and truth/{femur.vtp,BeamToProbe.json,FemurToCT.json}. serve
# holds its whole capture in memory, so the sweep is served again and again: OUT gets the sweep's
# samples once (soak.raw) and headers soak_NNN.igs.mhd over them, each with the timestamps re-spaced
# to 1/RATE s and going on from the previous one; they are served one after the other on PORT and
# live reconnects to each (--reconnect), one session and one recording (OUT/session.igs.mha)
# throughout, ended by --duration SECONDS. Files in OUT: rss.log (seconds since live started,
# VmHWM and VmRSS in kB, the partial recording's bytes, the final .mha's bytes, load average),
# live.err / live.out / live.time (its /usr/bin/time -v), session.json, serve_NNN.{out,err}.
# Disk: the headers (about 1 kB per frame each) and the recording (4 kB per A-line raw). Exits
# with live's exit code (1 also when its final registration did not converge).
set -u
bin=$1 study=$2 out=$3 seconds=${4:-600} rate=${5:-3000} port=${6:-19617}
sweep="$study/captures/femur_ultrasound.igs.mha"
mkdir -p "$out" || exit 1
rm -f "$out"/soak_*.igs.mhd "$out"/session.* "$out"/serve_* "$out"/rss.log

# The headers: enough for SECONDS at RATE, and two more.
python3 - "$sweep" "$out" "$seconds" "$rate" <<'EOF' || exit 1
import math, re, sys, zlib
src, out, seconds, rate = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
data = open(src, 'rb').read()
head, body = data.split(b'ElementDataFile = LOCAL\n', 1)
head = head.decode()
raw = zlib.decompress(body) if re.search(r'^CompressedData = True$', head, re.M) else body
open(f'{out}/soak.raw', 'wb').write(raw)
head = re.sub(r'^CompressedData = True\n', 'CompressedData = False\n', head, flags=re.M)
head = re.sub(r'^CompressedDataSize = \d+\n', '', head, flags=re.M)
parts = re.split(r'(Seq_Frame\d+_Timestamp = )[^\n]+', head)
frames = (len(parts) - 1) // 2
count = math.ceil(seconds * rate / frames) + 2
for k in range(count):
    t0 = 1000.0 + k * frames / rate
    text = [p if j % 2 == 0 else p + repr(round(t0 + (j // 2) / rate, 9))
            for j, p in enumerate(parts)]
    with open(f'{out}/soak_{k:03d}.igs.mhd', 'w') as f:
        f.write(''.join(text) + 'ElementDataFile = soak.raw\n')
print(f'{count} headers of {frames} frames at {rate:g}/s ({frames / rate:.1f} s each)')
EOF

serves=()
start_serve() {
  "$bin" serve "$out/soak_$1.igs.mhd" --port "$port" --wait 120 --rate recorded \
    > "$out/serve_$1.out" 2> "$out/serve_$1.err" &
  serves+=($!)
}
start_serve 000
until grep -q "waiting for a client" "$out/serve_000.err" 2>/dev/null; do
  kill -0 "${serves[0]}" 2>/dev/null || { cat "$out/serve_000.err"; exit 1; }
  sleep 0.2
done
/usr/bin/time -v -o "$out/live.time" "$bin" live --connect "127.0.0.1:$port" \
  --model "$study/truth/femur.vtp" --bone Femur --calibration "$study/truth/BeamToProbe.json" \
  --initial "$study/truth/FemurToCT.json" --record "$out/session.igs.mha" \
  --out "$out/FemurToCT.json" --session-json "$out/session.json" --reconnect 15 \
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

# The next serve starts once this one has its client (its listening socket is then closed).
k=0
while kill -0 "$timer" 2>/dev/null; do
  name=$(printf %03d $k)
  [ -f "$out/soak_$name.igs.mhd" ] || break
  [ $k -gt 0 ] && start_serve "$name"
  until grep -q "streaming to" "$out/serve_$name.err" 2>/dev/null; do
    kill -0 "$timer" 2>/dev/null || break 2
    sleep 0.1
  done
  k=$((k + 1))
done
wait "$timer"
status=$?
wait "$monitor"
for pid in "${serves[@]}"; do  # a serve still waiting for a client that will not come
  kill "$pid" 2>/dev/null
done
echo "live exit $status; $k serve(s) streamed; $out/rss.log:"
cat "$out/rss.log"
tail -n 3 "$out/live.err"
exit $status
