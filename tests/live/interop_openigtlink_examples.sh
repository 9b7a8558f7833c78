#!/usr/bin/env bash
# Interoperability with Debian's OpenIGTLink 1.11 examples (openigtlink-examples ships their
# sources): builds ReceiveServer, ReceiveClient, TrackerServer and ImagerServer into a temporary
# folder and runs them against echoreg inside new user and network namespaces (`unshare -rn`: no
# root needed where unprivileged user namespaces are allowed, as on Debian), where only loopback
# exists: the examples' servers bind every interface, which there is loopback alone. Exits 1 when
# a check fails, 77 (ctest: skipped) with a message when the examples, a C++ compiler or the
# namespaces are not available. ctest runs it as live_interop_openigtlink_examples on the fixture
# study; docs/live.md gives its results.
#
#   tests/live/interop_openigtlink_examples.sh ECHOREG STUDY_DIR
#
# STUDY_DIR: a simulated study (echoreg simulate --size small): its femur sweep is served, its
# truth model, calibration and FemurToCT (as the start) are live's inputs.
set -euo pipefail
examples=/usr/share/doc/openigtlink-examples/examples
if [ ! -d "$examples" ] || [ ! -e /usr/include/openigtlink/igtlClientSocket.h ]; then
  echo "SKIP: Debian's openigtlink-examples or libopenigtlink-dev is not installed" >&2
  exit 77
fi
if ! command -v g++ > /dev/null; then
  echo "SKIP: no g++ to build the OpenIGTLink examples" >&2
  exit 77
fi
if ! unshare -rn true 2> /dev/null; then
  echo "SKIP: unshare -rn (user and network namespaces) is not allowed here" >&2
  exit 77
fi
echoreg=$(realpath "$1")
study=$(realpath "$2")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for source in Receiver/ReceiveServer Receiver/ReceiveClient Tracker/TrackerServer Imager/ImagerServer; do
  g++ -O1 -w -I/usr/include/openigtlink "$examples/$source.cxx" -lOpenIGTLink -lpthread \
    -o "$work/$(basename "$source")"
done
live_inputs=(--model "$study/truth/femur.vtp" --bone Femur --calibration "$study/truth/BeamToProbe.json"
  --initial "$study/truth/FemurToCT.json")

unshare -rn bash -s "$echoreg" "$study" "$work" "${live_inputs[@]}" <<'INNER'
set -uo pipefail
echoreg=$1 study=$2 work=$3
shift 3
failures=0
check() {  # check DESCRIPTION CONDITION...
  local what=$1
  shift
  if "$@"; then
    echo "  ok: $what"
  else
    echo "  FAILED: $what"
    failures=$((failures + 1))
  fi
}
ip link set lo up
cd "$work"
capture="$study/captures/femur_ultrasound.igs.mha"

echo "== 1. ReceiveClient reads what echoreg serve sends"
"$echoreg" serve "$capture" --port 18944 --rate max --wait 10 > serve1.out 2> serve1.err &
sleep 3  # serve reads the capture before it listens
timeout 20 ./ReceiveClient 127.0.0.1 18944 > client.out 2>&1
wait
for type in TRANSFORM STATUS STRING IMAGE; do
  echo "  $type parsed: $(grep -c "Receiving $type data type" client.out)"
done
echo "  CRC failures reported: $(grep -ci "crc" client.out)"
cat serve1.out
frames=$(sed -n 's/.*served \([0-9]*\) of \([0-9]*\) frames.*/\1/p' serve1.out)
check "serve served every frame" grep -q "served $frames of $frames frames" serve1.out
check "ReceiveClient parsed one IMAGE per frame ($frames)" \
  test "$(grep -c "Receiving IMAGE data type" client.out)" = "${frames:-x}"
check "ReceiveClient parsed TRANSFORMs" test "$(grep -c "Receiving TRANSFORM data type" client.out)" -gt 0
check "ReceiveClient reported no CRC failure" test "$(grep -ci "crc" client.out)" = 0

echo "== 2. ReceiveServer reads what echoreg live sends back (serve -> live --send-to ReceiveServer)"
timeout 40 ./ReceiveServer 18945 > receiver.out 2>&1 &
receiver=$!
sleep 0.5
"$echoreg" serve "$capture" --port 18944 --rate recorded --wait 10 > serve2.out 2> serve2.err &
"$echoreg" live --connect 127.0.0.1:18944 --send-to 127.0.0.1:18945 --record live.igs.mha \
  --out live.json --idle-timeout 5 "$@" > live2.out 2> live2.err
live2=$?
echo "  live exit $live2"
wait %2 2>/dev/null
# ReceiveServer takes 100 messages per connection and then drops it; live connects again, so
# its last messages (the final registration on every point) reach the third or so connection.
# Wait until the receiver's output stops growing (at most 10 s) before stopping it.
size=-1
for _ in $(seq 20); do
  now=$(stat -c %s receiver.out)
  [ "$now" = "$size" ] && break
  size=$now
  sleep 0.5
done
kill $receiver 2>/dev/null
for type in TRANSFORM POINT STRING; do
  echo "  $type parsed: $(grep -c "Receiving $type data type" receiver.out)"
done
echo "  CRC failures reported: $(grep -ci "crc" receiver.out)"
cat live2.out
grep "results' receiver" live2.err | sed 's/^/  /'
check "live ended cleanly" test "$live2" = 0
check "live connected again when ReceiveServer dropped it after 100 messages" \
  grep -q "connected again to the results' receiver" live2.err
accepted=$(sed -n 's/.*; \([0-9]*\) echoes accepted live.*/\1/p' live2.out)
last_status=$(grep -A1 "Receiving STRING data type" receiver.out | tail -1)
echo "  last status received: $last_status"
check "ReceiveServer's last status is live's final fit, converged on all ${accepted:-?} points" \
  grep -q "mm, converged, ${accepted:-x} points" <<< "$last_status"
for type in TRANSFORM POINT STRING; do
  check "ReceiveServer parsed $type messages" \
    test "$(grep -c "Receiving $type data type" receiver.out)" -gt 0
done
check "ReceiveServer reported no CRC failure" test "$(grep -ci "crc" receiver.out)" = 0

echo "== 3. TrackerServer (TRANSFORM 'Tracker', no A-lines) into echoreg live"
./TrackerServer 18946 50 > tracker.out 2>&1 &
tracker=$!
sleep 0.5
"$echoreg" live --connect 127.0.0.1:18946 --record tracker.igs.mha --out t.json --duration 2 "$@" \
  > live3.out 2> live3.err
live3=$?
echo "  live exit $live3 (1 expected: no A-line to register)"
kill $tracker 2>/dev/null
grep -v "^$" live3.err | sed 's/^/  /'
"$echoreg" info tracker.igs.tracking.mha | sed 's/^/  /' | head -4
check "live exited 1 without an A-line" test "$live3" = 1
check "live said why" grep -q "no A-line (IMAGE of 1 x N) received" live3.err
check "TrackerServer's transforms are in the .tracking capture" test -s tracker.igs.tracking.mha

echo "== 4. ImagerServer (256 x 256 IMAGEs, not A-lines) into echoreg live"
./ImagerServer 18947 10 /usr/share/doc/openigtlink-examples/examples/Imager/img > imager.out 2>&1 &
imager=$!
sleep 0.5
"$echoreg" live --connect 127.0.0.1:18947 --record imager.igs.mha --out i.json --duration 2 "$@" \
  > live4.out 2> live4.err
live4=$?
echo "  live exit $live4 (1 expected: no A-line to register)"
kill $imager 2>/dev/null
grep -v "^$" live4.err | sed 's/^/  /'
check "live exited 1 without an A-line" test "$live4" = 1
check "live named the 256 x 256 IMAGEs as not A-lines" grep -q "is not an A-line (1 x N)" live4.err

echo "== $failures check(s) failed"
exit $((failures > 0))
INNER
