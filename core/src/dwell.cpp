// Dwell detection on a tracked stylus tip, and the tip's track in the reference marker's frame.
#include "echoreg/core/dwell.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace echoreg::core {

namespace {

double medianOf(std::vector<double>& v) {
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  double m = v[mid];
  if (v.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  return m;
}

// Component-wise median of positions[idx[from..to)].
Eigen::Vector3d medianPosition(const std::vector<Eigen::Vector3d>& positions,
                               const std::vector<std::size_t>& idx, std::size_t from,
                               std::size_t to) {
  Eigen::Vector3d m;
  std::vector<double> c;
  c.reserve(to - from);
  for (Eigen::Index k = 0; k < 3; ++k) {
    c.clear();
    for (std::size_t i = from; i < to; ++i)
      c.push_back(positions[idx[i]][k]);
    m[k] = medianOf(c);
  }
  return m;
}

struct Run {
  std::size_t begin = 0;  // into the valid-frame index list
  std::size_t end = 0;    // exclusive
};

// The run's stable core: its frames within maxMotionMm / 2 of its median (all of them when that
// leaves fewer than minFrames).
std::vector<std::size_t> stableCore(const std::vector<Eigen::Vector3d>& positions,
                                    const std::vector<std::size_t>& idx, const Run& run,
                                    const DwellOptions& options) {
  const Eigen::Vector3d median = medianPosition(positions, idx, run.begin, run.end);
  std::vector<std::size_t> core;
  for (std::size_t i = run.begin; i < run.end; ++i) {
    if ((positions[idx[i]] - median).norm() <= 0.5 * options.maxMotionMm)
      core.push_back(idx[i]);
  }
  if (static_cast<int>(core.size()) < options.minFrames) {
    core.assign(idx.begin() + static_cast<std::ptrdiff_t>(run.begin),
                idx.begin() + static_cast<std::ptrdiff_t>(run.end));
  }
  return core;
}

Eigen::Vector3d meanOf(const std::vector<Eigen::Vector3d>& positions,
                       const std::vector<std::size_t>& frames) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (std::size_t f : frames)
    m += positions[f];
  return m / static_cast<double>(frames.size());
}

}  // namespace

std::vector<Dwell> detectDwells(const std::vector<Eigen::Vector3d>& positions,
                                const std::vector<double>& timestampsS,
                                const std::vector<bool>& valid, const DwellOptions& options) {
  if (positions.size() != timestampsS.size() || positions.size() != valid.size()) {
    throw std::invalid_argument("detectDwells: " + std::to_string(positions.size()) +
                                " positions, " + std::to_string(timestampsS.size()) +
                                " timestamps and " + std::to_string(valid.size()) +
                                " validity flags differ in number");
  }
  if (!(options.maxMotionMm > 0.0) || !std::isfinite(options.maxMotionMm)) {
    throw std::invalid_argument("detectDwells: maxMotionMm must be > 0, got " +
                                std::to_string(options.maxMotionMm));
  }
  if (!(options.minDurationS >= 0.0) || !std::isfinite(options.minDurationS)) {
    throw std::invalid_argument("detectDwells: minDurationS must be >= 0, got " +
                                std::to_string(options.minDurationS));
  }
  if (!(options.smoothingS >= 0.0) || !std::isfinite(options.smoothingS)) {
    throw std::invalid_argument("detectDwells: smoothingS must be >= 0, got " +
                                std::to_string(options.smoothingS));
  }
  if (!(options.mergeDistanceMm >= 0.0) || !std::isfinite(options.mergeDistanceMm)) {
    throw std::invalid_argument("detectDwells: mergeDistanceMm must be >= 0, got " +
                                std::to_string(options.mergeDistanceMm));
  }
  if (options.minFrames < 2) {
    throw std::invalid_argument("detectDwells: minFrames must be >= 2, got " +
                                std::to_string(options.minFrames));
  }
  // The valid frames, checked.
  std::vector<std::size_t> idx;
  for (std::size_t f = 0; f < positions.size(); ++f) {
    if (!valid[f])
      continue;
    if (!positions[f].allFinite() || !std::isfinite(timestampsS[f])) {
      throw std::invalid_argument("detectDwells: frame " + std::to_string(f) +
                                  " is valid but its position or timestamp is not finite");
    }
    if (!idx.empty() && timestampsS[f] < timestampsS[idx.back()]) {
      throw std::invalid_argument("detectDwells: the timestamp of frame " + std::to_string(f) +
                                  " is earlier than that of frame " + std::to_string(idx.back()));
    }
    idx.push_back(f);
  }

  // Tracker noise and tremor smoothed away: the centred moving mean over smoothingS.
  std::vector<Eigen::Vector3d> smooth(positions.size(), Eigen::Vector3d::Zero());
  {
    std::size_t lo = 0;
    std::size_t hi = 0;  // window idx[lo..hi)
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    const double half = 0.5 * options.smoothingS;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const double t = timestampsS[idx[i]];
      while (hi < idx.size() && timestampsS[idx[hi]] <= t + half)
        sum += positions[idx[hi++]];
      while (timestampsS[idx[lo]] < t - half)
        sum -= positions[idx[lo++]];
      smooth[idx[i]] = sum / static_cast<double>(hi - lo);
    }
  }

  // Greedy runs of smoothed positions within maxMotionMm of the run's median.
  std::vector<Run> runs;
  std::size_t start = 0;
  while (start < idx.size()) {
    std::size_t end = start + 1;
    Eigen::Vector3d anchor = smooth[idx[start]];
    std::size_t anchoredAt = 1;  // run length when the anchor was last recomputed
    while (end < idx.size()) {
      if ((smooth[idx[end]] - anchor).norm() > options.maxMotionMm)
        break;
      ++end;
      if (end - start >= 2 * anchoredAt) {
        anchor = medianPosition(smooth, idx, start, end);
        anchoredAt = end - start;
        // A recomputed median may leave earlier frames outside: stop the run there.
        bool ok = true;
        for (std::size_t i = start; i < end && ok; ++i) {
          ok = (smooth[idx[i]] - anchor).norm() <= options.maxMotionMm;
        }
        if (!ok) {
          --end;
          break;
        }
      }
    }
    const double duration = timestampsS[idx[end - 1]] - timestampsS[idx[start]];
    const bool longEnough =
        duration >= options.minDurationS && static_cast<int>(end - start) >= options.minFrames;
    if (longEnough) {
      runs.push_back({start, end});
      start = end;
    } else {
      ++start;
    }
  }

  // Merge consecutive runs on the same spot (pivoting on the landmark, or a jitter split a rest).
  std::vector<Dwell> dwells;
  std::vector<std::size_t> core;  // the current dwell's frames
  for (const Run& r : runs) {
    std::vector<std::size_t> c = stableCore(positions, idx, r, options);
    if (!dwells.empty() &&
        (meanOf(positions, c) - dwells.back().meanMm).norm() < options.mergeDistanceMm) {
      core.insert(core.end(), c.begin(), c.end());
    } else {
      dwells.emplace_back();
      dwells.back().firstFrame = static_cast<int>(idx[r.begin]);
      core = std::move(c);
    }
    Dwell& d = dwells.back();
    d.lastFrame = static_cast<int>(idx[r.end - 1]);
    d.meanMm = meanOf(positions, core);
    double sum = 0.0;
    for (std::size_t f : core)
      sum += (positions[f] - d.meanMm).squaredNorm();
    d.spreadMm = std::sqrt(sum / static_cast<double>(core.size()));
    d.frames = static_cast<int>(core.size());
  }
  return dwells;
}

DwellMatch matchDwellsInOrder(const std::vector<Dwell>& dwells,
                              const std::vector<Eigen::Vector3d>& landmarks) {
  const std::size_t n = landmarks.size();
  const std::size_t m = dwells.size();
  if (n < 3) {
    throw std::invalid_argument(std::to_string(n) + " landmarks, at least 3 needed");
  }
  if (m < n) {
    throw std::invalid_argument("found " + std::to_string(m) + " dwells of the stylus for " +
                                std::to_string(n) + " landmarks");
  }
  // Choices of n of m in order: C(m, n).
  double choices = 1.0;
  for (std::size_t k = 0; k < n; ++k) {
    choices = choices * static_cast<double>(m - k) / static_cast<double>(k + 1);
  }
  if (choices > 2e6) {
    throw std::invalid_argument("found " + std::to_string(m) + " dwells for " + std::to_string(n) +
                                " landmarks: too many ways to choose (tighten the dwell options)");
  }
  DwellMatch best;
  best.runnerUpFreMm = std::numeric_limits<double>::infinity();
  best.candidates = 0;
  bool haveBest = false;
  std::string lastError;
  std::vector<std::size_t> pick(n);
  for (std::size_t k = 0; k < n; ++k)
    pick[k] = k;
  std::vector<Eigen::Vector3d> to(n);
  while (true) {
    for (std::size_t k = 0; k < n; ++k)
      to[k] = dwells[pick[k]].meanMm;
    ++best.candidates;
    try {
      PairedPointResult r = registerPairedPoints(landmarks, to);
      if (!haveBest || r.freMm < best.registration.freMm) {
        if (haveBest)
          best.runnerUpFreMm = best.registration.freMm;
        best.registration = std::move(r);
        best.dwellIndex.clear();
        for (std::size_t k : pick)
          best.dwellIndex.push_back(static_cast<int>(k));
        haveBest = true;
      } else if (r.freMm < best.runnerUpFreMm) {
        best.runnerUpFreMm = r.freMm;
      }
    } catch (const std::invalid_argument& e) {
      lastError = e.what();
    }
    // Next combination in lexicographic order.
    std::size_t k = n;
    while (k > 0 && pick[k - 1] == m - n + (k - 1))
      --k;
    if (k == 0)
      break;
    ++pick[k - 1];
    for (std::size_t j = k; j < n; ++j)
      pick[j] = pick[j - 1] + 1;
  }
  if (!haveBest)
    throw std::invalid_argument(lastError);
  return best;
}

StylusTrack stylusTipTrack(const Sequence& capture, const Eigen::Isometry3d& stylusTipToStylus,
                           const std::string& stylusTransform,
                           const std::string& referenceTransform) {
  const std::vector<std::string> names = capture.transformNames();
  auto has = [&](const std::string& n) {
    return std::find(names.begin(), names.end(), n) != names.end();
  };
  for (const std::string& n : {stylusTransform, referenceTransform}) {
    if (n.empty() || has(n))
      continue;
    std::string list;
    for (const std::string& h : names)
      list += (list.empty() ? "" : ", ") + h + "Transform";
    throw std::invalid_argument(
        "has no " + n + "Transform" +
        (list.empty() ? std::string(" (it has no transforms)") : " (it has " + list + ")"));
  }
  if (stylusTransform.empty())
    throw std::invalid_argument("the stylus transform name is empty");
  const Eigen::Vector3d tipInStylus = stylusTipToStylus.translation();
  StylusTrack track;
  const std::size_t n = capture.frames.size();
  track.tipInReference.assign(n, Eigen::Vector3d::Zero());
  track.timestampsS.assign(n, 0.0);
  track.valid.assign(n, false);
  int validCount = 0;
  for (std::size_t f = 0; f < n; ++f) {
    const SequenceFrame& frame = capture.frames[f];
    track.timestampsS[f] = frame.timestampS ? *frame.timestampS : static_cast<double>(f);
    const auto s = frame.transforms.find(stylusTransform);
    if (s == frame.transforms.end() || !s->second.valid())
      continue;
    Eigen::Isometry3d stylusToTracker;
    stylusToTracker.matrix() = s->second.matrix;
    Eigen::Vector3d tip = stylusToTracker * tipInStylus;
    if (!referenceTransform.empty()) {
      const auto r = frame.transforms.find(referenceTransform);
      if (r == frame.transforms.end() || !r->second.valid())
        continue;
      Eigen::Isometry3d referenceToTracker;
      referenceToTracker.matrix() = r->second.matrix;
      tip = referenceToTracker.inverse() * tip;
    }
    if (!tip.allFinite())
      continue;
    track.tipInReference[f] = tip;
    track.valid[f] = true;
    ++validCount;
  }
  if (validCount == 0) {
    throw std::invalid_argument(
        "none of its " + std::to_string(n) + " frames has a valid " + stylusTransform +
        "Transform" +
        (referenceTransform.empty() ? std::string() : " and " + referenceTransform + "Transform"));
  }
  return track;
}

}  // namespace echoreg::core
