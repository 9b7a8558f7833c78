#!/usr/bin/python3
"""Side-by-side check of echoreg's A-line chain against a numpy/scipy reimplementation.

    /usr/bin/python3 bench/compare_scipy.py OUT_DIR [--preset default|mozes2008 ...] [--repeats N]

OUT_DIR is what `export_records OUT_DIR --preset P` wrote: records.u8 (N x 4096 uint8),
labels.csv, decisions_<P>.csv and chain_<P>.txt (the C++ time per record and every parameter of
the chain as it ran, which this script uses, so preset changes in C++ need no edit here). Without
--preset every decisions_*.csv found is compared.

The chain is rebuilt here from core/src/{envelope,peaks,detection,butterworth}.cpp and
core/src/sample_sum.hpp, vectorised over blocks of records with numpy, scipy.signal.butter and
lfilter/filtfilt:

  sums     sumOfSamples: eight float32 lanes (x[i], x[i+8], ...) summed in order, the lanes then
           added in double (the mean of the record, the mean of the envelope)
  centre   float32(x) - float32(mean), ring-down zeroed
  envelope hann, W <= 32 (the default's 7): float32 weights
               w[k] = (0.5 - 0.5 cos(2 pi (k+1) / (W+1))) / sum(w), k = 0..W-1,
           over |x| in the centred window [i-h, i-h+W), h = (W-1)//2, zeros outside, summed in
           float32 in k order; W > 32: the same in double, times 2/(W+1), max(0, .)
           mozes: lfilter (causal) or filtfilt (zero-phase, odd padding of 3*len(a)) of |x|
  peaks    threshold = factor * sum(env) / n (double), compared in float32; runs of
           env > threshold, each run's first maximum
  policy   double: exactly two peaks, the second; bone: deepest peak with the bone signature:
           screen value >= contrast * tissue-over-noise * noise floor, half-maximum width,
           median of the region before (every 8th sample, rank n//2), tissue over noise,
           contrast, shadow medians after (near half and whole); noise floor = rank n//10 of the
           positive samples among every 32nd
  refine   parabola through the neighbours (when subsample is on), depth = (i/fs + delay) c / 2

It prints a Markdown table (decisions identical, max |delta sample| of records both accepted,
Python vs C++ time per record) and exits 1 when decisions differ in more than 0.5 % of the records
or any sample index differs by more than one sample.
"""

import argparse
import csv
import math
import pathlib
import sys
import time

import numpy as np
import scipy
import scipy.signal

MAX_DISAGREEMENT = 0.005  # fraction of records whose accept/reject decisions may differ
MAX_SAMPLE_DELTA = 1.0    # samples, among records both accepted
CHUNK_RECORDS = 256       # records per vectorised block: a block's arrays stay in the caches

# Fixed choices of the C++ code (not parameters): see the functions that use them.
SUM_LANES = 8             # sample_sum.hpp
DIRECT_HANN_MAX = 32      # envelope.cpp, kDirectHannMaxWindow
MEDIAN_STRIDE = 8         # peaks.cpp, medianOf
NOISE_STRIDE = 32         # peaks.cpp, noiseFloorOf


def lround(x):
    """C's lround (halves away from zero)."""
    return int(math.floor(x + 0.5)) if x >= 0 else -int(math.floor(-x + 0.5))


# ------------------------------------------------------------------------------------ parameters

def read_key_values(path):
    values = {}
    for line in path.read_text().splitlines():
        if "=" in line:
            key, value = line.split("=", 1)
            values[key.strip()] = value.strip()
    return values


def chain_params(info):
    """The chain's parameters from chain_<preset>.txt (written by export_records)."""
    def number(key):
        return float(info[key])

    params = {
        "envelope": {
            "method": info["envelope_method"],
            "ring_down": int(info["ring_down_samples"]),
            "window": int(info["window_samples"]),
            "order": int(info["butterworth_order"]),
            "cutoff": number("butterworth_cutoff"),
            "zero_phase": info["butterworth_zero_phase"] == "1",
        },
        "threshold_mode": info["threshold_mode"],
        "threshold_factor": number("threshold_factor"),
        "policy": info["policy"],
        "subsample": info["subsample"] == "1",
        "mm_per_sample": number("mm_per_sample"),
        "bone": {
            "region_mm": number("bone_region_mm"),
            "gap_mm": number("bone_gap_mm"),
            "min_shadow_ratio": number("bone_min_shadow_ratio"),
            "min_contrast": number("bone_min_contrast"),
            "max_width_mm": number("bone_max_width_mm"),
            "noise_floor_factor": number("bone_noise_floor_factor"),
            "min_tissue_over_noise": number("bone_min_tissue_over_noise"),
        },
        "depth": {
            "fs_hz": number("sampling_frequency_hz"),
            "delay_s": number("delay_s"),
            "speed_mps": number("speed_of_sound_mps"),
        },
    }
    unsupported = []
    if params["envelope"]["method"] not in ("hann", "mozes"):
        unsupported.append("envelope " + params["envelope"]["method"])
    if params["threshold_mode"] != "factor-of-mean":
        unsupported.append("threshold mode " + params["threshold_mode"])
    if params["policy"] not in ("double", "bone"):
        unsupported.append("policy " + params["policy"])
    if info.get("window_begin") or info.get("window_end"):
        unsupported.append("a processing window")
    if unsupported:
        raise SystemExit("compare_scipy.py does not reimplement " + ", ".join(unsupported))
    return params


# ------------------------------------------------------------------------------------------ chain

def sum_of_samples(x):
    """detail::sumOfSamples per row of float32 `x`: eight float32 lanes, then double."""
    n, count = x.shape
    whole = count // SUM_LANES * SUM_LANES
    total = np.zeros(n)
    if whole:
        lanes = x[:, :whole].reshape(n, -1, SUM_LANES)
        partial = np.cumsum(lanes, axis=1, dtype=np.float32)[:, -1, :]  # in order, in float32
        for lane in range(SUM_LANES):
            total += partial[:, lane].astype(np.float64)
    for i in range(whole, count):
        total += x[:, i].astype(np.float64)
    return total


def record_means(x):
    return (sum_of_samples(x) / x.shape[1]).astype(np.float32)


def rectified_padded(x, mean, ring_down, left, right, dtype):
    """|x - mean| (float32) with the ring-down zeroed, `left`/`right` zeros around it."""
    n, count = x.shape
    out = np.zeros((n, left + count + right), dtype=dtype)
    ring_down = min(ring_down, count)
    out[:, left + ring_down:left + count] = np.abs(x[:, ring_down:] - mean[:, None])
    return out


def hann_weights(window):
    raw = [0.5 - 0.5 * math.cos(2.0 * math.pi * (k + 1) / (window + 1)) for k in range(window)]
    return raw, sum(raw)  # math.cos: the same libm as the C++ std::cos


def hann_envelope(x, window, ring_down):
    n, count = x.shape
    h = (window - 1) // 2
    mean = record_means(x)
    raw, total = hann_weights(window)
    if window <= DIRECT_HANN_MAX:
        # hannDirect: float32 weights normalised by their double sum, float32 sums in k order.
        weights = np.array([w / total for w in raw], dtype=np.float32)
        padded = rectified_padded(x, mean, ring_down, h, window, np.float32)
        acc = np.zeros((n, count), dtype=np.float32)
        for k in range(window):
            acc += weights[k] * padded[:, k:k + count]
        return acc
    # The prefix-sum form: the same definition in double, normalised by 2/(W+1).
    padded = rectified_padded(x, mean, ring_down, h, window, np.float64)
    weights = np.array(raw)
    acc = weights[0] * padded[:, 0:count]
    for k in range(1, window):
        acc += weights[k] * padded[:, k:k + count]
    np.maximum(acc, 0.0, out=acc)
    acc *= 2.0 / (window + 1)
    return acc.astype(np.float32)


def butterworth(order, cutoff):
    return scipy.signal.butter(order, cutoff, btype="low", output="ba")


def mozes_envelope(x, order, cutoff, zero_phase, ring_down):
    b, a = butterworth(order, cutoff)
    rectified = rectified_padded(x, record_means(x), ring_down, 0, 0, np.float32)
    rectified = rectified.astype(np.float64)
    if zero_phase:
        out = scipy.signal.filtfilt(b, a, rectified, axis=1, padtype="odd",
                                    padlen=3 * max(len(a), len(b)))
    else:
        out = scipy.signal.lfilter(b, a, rectified, axis=1)
    return out.astype(np.float32)


def envelope_of(raw, params):
    x = raw.astype(np.float32)  # the uint8 -> float conversion, as the C++ timing includes it
    if params["method"] == "hann":
        return hann_envelope(x, params["window"], params["ring_down"])
    return mozes_envelope(x, params["order"], params["cutoff"], params["zero_phase"],
                          params["ring_down"])


def find_runs(env, factor):
    """Threshold (double) and every run above it: (threshold, record, peak index, peak value),
    the peaks in record order, then position order."""
    n, count = env.shape
    threshold = factor * sum_of_samples(env) / count
    # One -inf column after every record keeps runs inside their record.
    stride = count + 1
    values = np.full((n, stride), -np.inf, dtype=np.float32)
    values[:, :count] = env
    above = values > threshold.astype(np.float32)[:, None]
    values = values.ravel()
    above = above.ravel()
    edges = np.diff(above.view(np.int8), prepend=np.int8(0))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    if starts.size == 0:
        empty = np.zeros(0, dtype=np.int64)
        return threshold, empty, empty, np.zeros(0, dtype=np.float32)
    bounds = np.empty(2 * starts.size, dtype=np.int64)
    bounds[0::2] = starts
    bounds[1::2] = ends
    run_max = np.maximum.reduceat(values, bounds)[0::2]  # max over [start, end)
    # The first maximum of each run (the C++ keeps the first of equal maxima).
    lengths = ends - starts
    inside = np.flatnonzero(above)                          # the runs, one after the other
    run_of = np.repeat(np.arange(starts.size), lengths)
    at_max = values[inside] == run_max[run_of]
    hit_run = run_of[at_max]
    first = np.ones(hit_run.size, dtype=bool)
    first[1:] = hit_run[1:] != hit_run[:-1]
    peak_flat = inside[at_max][first]
    return threshold, starts // stride, peak_flat % stride, run_max


def medians(env, record, begin, end):
    """medianOf for many windows at once: env[record, begin:end] clipped to the record, every
    MEDIAN_STRIDE-th sample from the clipped begin, the element of rank n//2; -1 if empty."""
    count = env.shape[1]
    begin = np.maximum(begin, 0)
    end = np.minimum(end, count)
    size = np.where(end > begin, (end - begin + MEDIAN_STRIDE - 1) // MEDIAN_STRIDE, 0)
    out = np.full(record.shape, -1.0)
    for m in np.unique(size[size > 0]):
        which = np.flatnonzero(size == m)
        cols = begin[which, None] + MEDIAN_STRIDE * np.arange(m)
        block = env[record[which, None], cols]
        out[which] = np.partition(block, m // 2, axis=1)[:, m // 2]
    return out


def noise_floors(env):
    """noiseFloorOf: rank n//10 of the positive samples among every NOISE_STRIDE-th; 0 if none."""
    sub = env[:, ::NOISE_STRIDE]
    positive = sub > 0.0
    ranked = np.sort(np.where(positive, sub, np.inf), axis=1)
    size = positive.sum(axis=1)
    floor = ranked[np.arange(env.shape[0]), np.minimum(size // 10, sub.shape[1] - 1)]
    return np.where(size > 0, floor, 0.0).astype(np.float64)


def bone_signature(env, record, index, value, noise_floor, bone, mm):
    """hasBoneSignature of peaks.cpp for every peak at once; a boolean per peak. The tests run
    in the C++ order, each on the peaks the earlier ones left."""
    count = env.shape[1]
    floor = noise_floor[record]
    value64 = value.astype(np.float64)
    ok = ~(value64 < bone["min_contrast"] * bone["min_tissue_over_noise"] * floor)

    # Full width at half maximum, counted up to the widest width that still passes.
    widest = 0
    while (widest + 1) * mm <= bone["max_width_mm"]:
        widest += 1
    half = value * np.float32(0.5)
    left = np.zeros(index.shape, dtype=np.int64)
    right = np.zeros(index.shape, dtype=np.int64)
    going_left = ok.copy()
    going_right = ok.copy()
    for step in range(1, widest + 1):
        at = index - step
        going_left &= at >= 0
        going_left[going_left] &= env[record[going_left], at[going_left]] > half[going_left]
        left += going_left
        at = index + step
        going_right &= at <= count - 1
        going_right[going_right] &= env[record[going_right], at[going_right]] > half[going_right]
        right += going_right
        if not (going_left.any() or going_right.any()):
            break
    ok &= (left + right + 1) * mm <= bone["max_width_mm"]

    region = max(1, lround(bone["region_mm"] / mm))
    gap = lround(bone["gap_mm"] / mm)
    after_begin = index + gap + 1
    after_end = after_begin + region
    ok &= ~(np.minimum(after_end, count) - after_begin < region // 2)

    live = np.flatnonzero(ok)
    before = np.full(index.shape, -1.0)
    before[live] = medians(env, record[live], index[live] - gap - region, index[live] - gap)
    ok &= ~((before < 0.0) | (before < bone["min_tissue_over_noise"] * floor))
    tiny = 1e-12
    ok &= ~(value64 < bone["min_contrast"] * np.maximum(before, tiny))

    for end in (after_begin + region // 2, after_end):
        live = np.flatnonzero(ok)
        after = medians(env, record[live], after_begin[live], end[live])
        shadow = ((before[live] >= bone["min_shadow_ratio"] * np.maximum(after, tiny)) |
                  (after <= bone["noise_floor_factor"] * floor[live]))
        ok[live] &= shadow
    return ok


def refine(env, record, index):
    """Parabolic vertex through the neighbours, within half a sample (refinedIndex)."""
    count = env.shape[1]
    result = index.astype(np.float64)
    inner = (index > 0) & (index < count - 1)
    r, i = record[inner], index[inner]
    left = env[r, i - 1].astype(np.float64)
    centre = env[r, i].astype(np.float64)
    right = env[r, i + 1].astype(np.float64)
    curvature = left - 2.0 * centre + right
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.clip(0.5 * (left - right) / curvature, -0.5, 0.5)
    result[inner] = np.where(curvature < 0.0, i + offset, i)
    return result


def run_chain(raw, params, chunk=CHUNK_RECORDS):
    """Decisions for every record: accepted (bool), reason (str), sample index, depth (mm),
    number of peaks and threshold, computed in blocks of `chunk` records."""
    parts = [run_block(raw[i:i + chunk], params) for i in range(0, raw.shape[0], chunk)]
    return {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}


def run_block(raw, params):
    env = envelope_of(raw, params["envelope"])
    n = env.shape[0]
    threshold, record, index, value = find_runs(env, params["threshold_factor"])
    found = np.bincount(record, minlength=n)
    accepted = np.zeros(n, dtype=bool)
    chosen = np.full(n, -1, dtype=np.int64)   # sample index of the chosen peak
    reason = np.full(n, "no-peak", dtype=object)
    if params["policy"] == "double":
        two = found == 2
        accepted[two] = True
        last = np.cumsum(found) - 1       # the second of two peaks is its record's last
        chosen[two] = index[last[two]]
        reason[found == 1] = "too-few-peaks"
        reason[found > 2] = "too-many-peaks"
    else:  # bone
        reason[found > 0] = "not-bone"
        bone = bone_signature(env, record, index, value, noise_floors(env), params["bone"],
                              params["mm_per_sample"])
        hit = np.flatnonzero(bone)
        np.maximum.at(chosen, record[hit], index[hit])  # the deepest peak with the signature
        accepted[record[hit]] = True
    reason[accepted] = "accepted"
    sample = np.full(n, np.nan)
    take = np.flatnonzero(accepted)
    sample[take] = refine(env, take, chosen[take]) if params["subsample"] else chosen[take]
    depth = params["depth"]
    return {
        "accepted": accepted,
        "reason": reason,
        "sample": sample,
        "depth": (sample / depth["fs_hz"] + depth["delay_s"]) * depth["speed_mps"] * 1000.0 / 2.0,
        "peaks": found,
        "threshold": threshold,
    }


# ------------------------------------------------------------------------------------ comparison

def read_decisions(path):
    accepted, reason, sample, depth, peaks, threshold = [], [], [], [], [], []
    with path.open(newline="") as f:
        for row in csv.DictReader(f):
            accepted.append(row["accepted"] == "1")
            reason.append(row["reason"])
            sample.append(float(row["sample_index"]) if row["sample_index"] else math.nan)
            depth.append(float(row["depth_mm"]) if row["depth_mm"] else math.nan)
            peaks.append(int(row["peaks"]) if row.get("peaks") else -1)
            threshold.append(float(row["threshold"]) if row.get("threshold") else math.nan)
    return {
        "accepted": np.array(accepted),
        "reason": np.array(reason, dtype=object),
        "sample": np.array(sample),
        "depth": np.array(depth),
        "peaks": np.array(peaks),
        "threshold": np.array(threshold),
    }


def read_labels(path):
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def check_butterworth(info):
    """Direct check of designButterworthLowPass (coefficients written by export_records)."""
    if "butterworth_b" not in info:
        return None
    order = int(info["butterworth_order"])
    cutoff = float(info["butterworth_cutoff"])
    b_cpp = np.array([float(v) for v in info["butterworth_b"].split(",")])
    a_cpp = np.array([float(v) for v in info["butterworth_a"].split(",")])
    b_py, a_py = butterworth(order, cutoff)
    b_rel = float(np.max(np.abs(b_cpp - b_py) / np.abs(b_py)))
    a_rel = float(np.max(np.abs(a_cpp - a_py) / np.maximum(np.abs(a_py), 1e-300)))
    print(f"scipy.signal.butter({order}, {cutoff:g}): b={np.array2string(b_py, precision=10)} "
          f"a={np.array2string(a_py, precision=10)}; max relative difference to echoreg's "
          f"designButterworthLowPass: b {b_rel:.1e}, a {a_rel:.1e}")
    return max(b_rel, a_rel)


def compare(out_dir, preset, repeats):
    for name in (f"chain_{preset}.txt", f"decisions_{preset}.csv", "records.u8", "labels.csv"):
        if not (out_dir / name).exists():
            raise SystemExit(f"{out_dir / name} is missing: run `export_records {out_dir} "
                             f"--preset {preset}` first")
    info = read_key_values(out_dir / f"chain_{preset}.txt")
    params = chain_params(info)
    samples = int(info.get("samples", 4096))
    raw = np.fromfile(out_dir / "records.u8", dtype=np.uint8)
    if raw.size % samples:
        raise SystemExit(f"records.u8 is not a whole number of {samples}-sample records")
    raw = raw.reshape(-1, samples)
    cpp = read_decisions(out_dir / f"decisions_{preset}.csv")
    labels = read_labels(out_dir / "labels.csv")
    n = raw.shape[0]
    if cpp["accepted"].size != n or len(labels) != n:
        raise SystemExit(f"{preset}: records.u8 has {n} records, decisions "
                         f"{cpp['accepted'].size}, labels {len(labels)}")

    print(f"\n{preset}: envelope {params['envelope']['method']}, policy {params['policy']}")
    check_butterworth(info)

    best = math.inf
    py = None
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        py = run_chain(raw, params)   # from the uint8 bytes, conversion included
        best = min(best, time.perf_counter() - start)
    py_per_record = best / n
    cpp_per_record = float(info["seconds_per_record"])

    same = py["accepted"] == cpp["accepted"]
    same_reason = py["reason"] == cpp["reason"]
    both = py["accepted"] & cpp["accepted"]
    delta = np.abs(py["sample"][both] - cpp["sample"][both])
    depth_delta = np.abs(py["depth"][both] - cpp["depth"][both])
    max_delta = float(delta.max()) if delta.size else 0.0
    max_depth_delta = float(depth_delta.max()) if depth_delta.size else 0.0
    differing = int((~same).sum())
    far = int((delta > MAX_SAMPLE_DELTA).sum())
    exact_position = int((delta == 0.0).sum())
    same_threshold = int((py["threshold"] == cpp["threshold"]).sum())
    threshold_rel = float(np.max(np.abs(py["threshold"] - cpp["threshold"]) /
                                 np.maximum(np.abs(cpp["threshold"]), 1e-30)))
    same_peaks = int((py["peaks"] == cpp["peaks"]).sum())

    print(f"{n} records; thresholds (double) identical in {same_threshold} (max relative "
          f"difference {threshold_rel:.1e}), peak counts identical in {same_peaks}, reasons "
          f"identical in {int(same_reason.sum())}; sample index bit-identical in "
          f"{exact_position} of {int(both.sum())} accepted by both")
    problems = np.flatnonzero(~same | ~same_reason |
                              (both & (np.abs(py["sample"] - cpp["sample"]) > MAX_SAMPLE_DELTA)))
    for i in problems[:25]:
        print(f"  record {i} ({labels[i]['kind']}, has_bone={labels[i]['has_bone']}, "
              f"bone_sample={labels[i]['bone_sample']}): C++ {cpp['reason'][i]} "
              f"{cpp['sample'][i]:.3f} ({cpp['peaks'][i]} peaks, threshold "
              f"{cpp['threshold'][i]:.7g}) vs Python {py['reason'][i]} {py['sample'][i]:.3f} "
              f"({py['peaks'][i]} peaks, threshold {py['threshold'][i]:.7g})")
    if problems.size > 25:
        print(f"  ... and {problems.size - 25} more")

    return {
        "preset": preset,
        "records": n,
        "same": int(same.sum()),
        "same_reason": int(same_reason.sum()),
        "both": int(both.sum()),
        "max_delta": max_delta,
        "max_depth_delta": max_depth_delta,
        "cpp_us": cpp_per_record * 1e6,
        "py_us": py_per_record * 1e6,
        "ratio": py_per_record / cpp_per_record,
        "passed": differing <= MAX_DISAGREEMENT * n and far == 0,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", type=pathlib.Path)
    parser.add_argument("--preset", action="append",
                        help="preset(s) to compare (default: every decisions_*.csv present)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="timed runs of the Python chain, best taken (default 3)")
    args = parser.parse_args()

    presets = args.preset or sorted(p.stem[len("decisions_"):]
                                    for p in args.out_dir.glob("decisions_*.csv"))
    if not presets:
        raise SystemExit(f"no decisions_<preset>.csv in {args.out_dir}; run export_records first")
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, Python {sys.version.split()[0]}")
    results = [compare(args.out_dir, preset, args.repeats) for preset in presets]

    print("\n| preset | records | identical accept/reject | identical reason | accepted by both "
          "| max abs delta sample | max abs delta depth (mm) | C++ us/record | Python us/record "
          "| Python / C++ | verdict |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for r in results:
        print(f"| {r['preset']} | {r['records']} "
              f"| {r['same']} ({100.0 * r['same'] / r['records']:.2f} %) | {r['same_reason']} "
              f"| {r['both']} | {r['max_delta']:.3g} | {r['max_depth_delta']:.3g} "
              f"| {r['cpp_us']:.2f} | {r['py_us']:.2f} | {r['ratio']:.1f}x "
              f"| {'ok' if r['passed'] else 'FAIL'} |")
    failed = [r["preset"] for r in results if not r["passed"]]
    if failed:
        print(f"\nFAIL: {', '.join(failed)}: decisions differ in more than "
              f"{100 * MAX_DISAGREEMENT:.1f} % of the records or a sample index by more than "
              f"{MAX_SAMPLE_DELTA:g} sample")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
