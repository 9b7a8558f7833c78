#!/usr/bin/env bash
# Runs the signal-chain benchmarks and the side-by-side scipy comparison (called by `make bench`).
#
#   bench/run_benchmarks.sh [BUILD_DIR]        (default build/release)
#
# BUILD_DIR must be configured with ECHOREG_BUILD_BENCH=ON; the two bench targets are (re)built in
# it if needed. Environment knobs:
#   BENCH_MIN_TIME     --benchmark_min_time per benchmark, seconds (default 0.2)
#   BENCH_REPETITIONS  repetitions of each benchmark, median/mean/stddev reported (default 3)
#   BENCH_FILTER       --benchmark_filter regex (default: all)
#   RECORDS            records for export_records / compare_scipy.py (default 2000)
#   OUT_DIR            where records, labels, decisions and the JSON results go
#                      (default BUILD_DIR/bench-out)
#   PYTHON             interpreter with numpy and scipy (default /usr/bin/python3)
# With the defaults the whole run takes about 25 s on 2 idle cores (under 2 minutes when busy).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
build="${1:-build/release}"
min_time="${BENCH_MIN_TIME:-0.2}"
repetitions="${BENCH_REPETITIONS:-3}"
filter="${BENCH_FILTER:-.}"
records="${RECORDS:-2000}"
out="${OUT_DIR:-$build/bench-out}"
python="${PYTHON:-/usr/bin/python3}"

if [[ ! -f "$build/CMakeCache.txt" ]]; then
  echo "run_benchmarks.sh: $build is not a configured build directory" >&2
  echo "  configure it first, e.g. cmake --preset release (or cmake -S . -B $build -DECHOREG_BUILD_BENCH=ON)" >&2
  exit 2
fi
if ! grep -q '^ECHOREG_BUILD_BENCH:BOOL=ON' "$build/CMakeCache.txt"; then
  echo "run_benchmarks.sh: $build has ECHOREG_BUILD_BENCH off; reconfigure with -DECHOREG_BUILD_BENCH=ON" >&2
  exit 2
fi
cmake --build "$build" --target bench_signal_chain export_records bench_mesh_locator \
  bench_simulation bench_livewire bench_registration --parallel "${JOBS:-2}"
bench="$build/bench/bench_signal_chain"
export_records="$build/bench/export_records"
mkdir -p "$out"

echo "== machine"
echo "nproc: $(nproc)"
echo "cpu:   $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
echo "load:  $(cut -d' ' -f1-3 /proc/loadavg)"

echo
echo "== Google Benchmark: records/s per envelope and per chain (1 thread and all cores)"
"$bench" --benchmark_min_time="$min_time" --benchmark_repetitions="$repetitions" \
  --benchmark_report_aggregates_only=true --benchmark_filter="$filter" \
  --benchmark_counters_tabular=true \
  --benchmark_out="$out/bench_signal_chain.json" --benchmark_out_format=json

echo
echo "== echoreg vs numpy/scipy on $records labelled records"
# The scipy twin implements the bone (shadow) and double policies, not the prominence policy of
# today's default (docs/benchmarks.md).
for preset in shadow mozes2008; do
  "$export_records" "$out" --records "$records" --preset "$preset"
done
"$python" "$here/compare_scipy.py" "$out" --preset shadow --preset mozes2008

# bench_livewire prints its path agreement with OpenCV first (when built with OpenCV).
for program in bench_mesh_locator bench_simulation bench_livewire bench_registration; do
  echo
  echo "== $program"
  "$build/bench/$program" --benchmark_min_time="$min_time" --benchmark_repetitions="$repetitions" \
    --benchmark_report_aggregates_only=true --benchmark_filter="$filter" \
    --benchmark_out="$out/$program.json" --benchmark_out_format=json
done
