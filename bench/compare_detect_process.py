#!/usr/bin/python3
"""Whole-process time of `echoreg detect` against the same chain in numpy/scipy, side by side.

    /usr/bin/python3 bench/compare_detect_process.py ECHOREG OUT_DIR [--preset shadow] [--repeats 5]

OUT_DIR is what `export_records OUT_DIR --records N --preset P` wrote (records.u8 and
chain_<P>.txt). The records are wrapped as a PLUS capture (records_to_capture.py), then, each as
its own process, best of --repeats wall-clock runs:

  echoreg  ECHOREG detect OUT_DIR/records.igs.mha --preset P --out detect.csv: read the file,
           the pipeline (envelope, peaks, beam points, inter-signal), write the CSV;
  scipy    /usr/bin/python3 importing numpy/scipy and compare_scipy.py, reading records.u8, the
           chain of compare_scipy.run_chain (envelope, peaks, policy, refinement, depth) and
           writing its decisions as CSV: the same chain without the inter-signal filters.

Prints a Markdown table (records, both times, the ratio) and the machine's load average, since
the cores are shared.
"""
import argparse
import os
import pathlib
import resource
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent

SCIPY_PROCESS = r"""
import pathlib, sys
import numpy as np
sys.path.insert(0, {here!r})
import compare_scipy as c
out = pathlib.Path({out!r})
info = c.read_key_values(out / "chain_{preset}.txt")
params = c.chain_params(info)
samples = int(info.get("samples", 4096))
raw = np.fromfile(out / "records.u8", dtype=np.uint8).reshape(-1, samples)
result = c.run_chain(raw, params)
with open(out / "scipy_decisions.csv", "w") as f:
    f.write("index,accepted,sample_index,depth_mm\n")
    for i in range(raw.shape[0]):
        f.write(f"{{i}},{{int(result['accepted'][i])}},{{result['sample'][i]:.3f}},"
                f"{{result['depth'][i]:.4f}}\n")
"""


def best_run(command, repeats):
    """(best wall-clock seconds, CPU seconds user + system of that run) over `repeats` runs."""
    best = (float("inf"), 0.0)
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        best = min(best, (wall, cpu))
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("echoreg", type=pathlib.Path)
    parser.add_argument("out_dir", type=pathlib.Path)
    parser.add_argument("--preset", default="shadow")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    records = args.out_dir / "records.u8"
    chain = args.out_dir / f"chain_{args.preset}.txt"
    for needed in (records, chain):
        if not needed.exists():
            raise SystemExit(f"{needed} is missing: run `export_records {args.out_dir} "
                             f"--records 9000 --preset {args.preset}` first")
    capture = args.out_dir / "records.igs.mha"
    subprocess.run([sys.executable, str(HERE / "records_to_capture.py"), str(records),
                    str(capture)], check=True, stdout=subprocess.DEVNULL)
    count = records.stat().st_size // 4096

    echoreg = [str(args.echoreg), "detect", str(capture), "--preset", args.preset, "--out",
               str(args.out_dir / "detect.csv")]
    scipy = ["/usr/bin/python3", "-c",
             SCIPY_PROCESS.format(here=str(HERE), out=str(args.out_dir), preset=args.preset)]
    echoreg_s, echoreg_cpu = best_run(echoreg, args.repeats)
    scipy_s, scipy_cpu = best_run(scipy, max(1, args.repeats // 2))
    load = os.getloadavg()
    print("| records | preset | echoreg detect: wall (CPU) | scipy chain: wall (CPU) "
          "| scipy / echoreg, wall | CPU |")
    print("|---:|---|---:|---:|---:|---:|")
    print(f"| {count} | {args.preset} | {echoreg_s:.3f} s ({echoreg_cpu:.3f} s) "
          f"| {scipy_s:.3f} s ({scipy_cpu:.3f} s) | {scipy_s / echoreg_s:.1f}x "
          f"| {scipy_cpu / echoreg_cpu:.1f}x |")
    print(f"\nbest of {args.repeats} (echoreg) and {max(1, args.repeats // 2)} (scipy) runs; "
          f"load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
