#!/usr/bin/python3
"""Start-up time of echoreg processes: `BINARY --version`, each binary in turn, N rounds.

    /usr/bin/python3 bench/startup_time.py N ECHOREG [ECHOREG ...]

Runs the binaries interleaved (one of each per round), so that two builds compared on a shared
machine see the same load, and prints per binary the median wall-clock and CPU (user + system)
time of the N runs, with the load average before and after.
"""
import os
import resource
import statistics
import subprocess
import sys
import time


def main():
    if len(sys.argv) < 3 or not sys.argv[1].isdigit() or int(sys.argv[1]) < 1:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    rounds = int(sys.argv[1])
    binaries = sys.argv[2:]
    wall = {b: [] for b in binaries}
    cpu = {b: [] for b in binaries}
    load_before = os.getloadavg()
    for _ in range(rounds):
        for binary in binaries:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run([binary, "--version"], stdout=subprocess.DEVNULL, check=True)
            wall[binary].append(time.perf_counter() - start)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu[binary].append((after.ru_utime - before.ru_utime) +
                               (after.ru_stime - before.ru_stime))
    load_after = os.getloadavg()
    print(f"load average {load_before[0]:.1f} before, {load_after[0]:.1f} after, "
          f"on {os.cpu_count()} cores; median of {rounds} runs of `--version`")
    for binary in binaries:
        print(f"{binary}: wall {statistics.median(wall[binary]) * 1000:.0f} ms, "
              f"CPU {statistics.median(cpu[binary]) * 1000:.0f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
