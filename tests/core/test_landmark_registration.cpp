// Paired-point registration, Fitzpatrick's expected errors (checked by Monte Carlo), dwell
// detection on synthetic stylus tracks, and the real golden: PLUS's own phantom registration from
// a stylus dwelling on eight landmarks (EightLandmarkPointsTrackedForPhantomRegistration).
#include "echoreg/core/dwell.hpp"
#include "echoreg/core/paired_point.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/core/sequence.hpp"
#include "plus_config.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

using test::thrownMessage;

Eigen::Isometry3d someTransform() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(35.0 * kDeg, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()) *
                Eigen::AngleAxisd(-120.0 * kDeg, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3d(120.5, -33.0, 812.25);
  return t;
}

// Four knee landmarks (epicondyles, malleoli) in CT, mm.
std::vector<Eigen::Vector3d> kneeLandmarks() {
  return {{-45.0, 10.0, 0.0}, {42.0, 12.0, 3.0}, {-30.0, 5.0, -380.0}, {35.0, -8.0, -372.0}};
}

double angleBetweenDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() / kDeg;
}

TEST(PairedPoint, RecoversAnExactTransform) {
  const Eigen::Isometry3d truth = someTransform();
  const auto from = kneeLandmarks();
  std::vector<Eigen::Vector3d> to;
  for (const auto& p : from)
    to.push_back(truth * p);
  const PairedPointResult r = registerPairedPoints(from, to);
  EXPECT_LT((r.transform.matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(r.transform.linear().determinant(), 1.0, 1e-12);
  EXPECT_LT(r.freMm, 1e-9);
  ASSERT_EQ(r.residualsMm.size(), from.size());
}

TEST(PairedPoint, WeightsPullTowardsTrustedPairs) {
  const Eigen::Isometry3d truth = someTransform();
  const std::vector<Eigen::Vector3d> from = {
      {0, 0, 0}, {60, 0, 0}, {0, 60, 0}, {0, 0, 60}, {40, 40, 40}};
  std::vector<Eigen::Vector3d> to;
  for (const auto& p : from)
    to.push_back(truth * p);
  to[4] += Eigen::Vector3d(6.0, -4.0, 3.0);  // one badly localised landmark
  const PairedPointResult even = registerPairedPoints(from, to);
  const PairedPointResult weighted = registerPairedPoints(from, to, {1, 1, 1, 1, 0.001});
  const PairedPointResult ignored = registerPairedPoints(from, to, {1, 1, 1, 1, 0});
  const auto err = [&](const PairedPointResult& r) {
    double worst = 0.0;
    for (const auto& p : from)
      worst = std::max(worst, (r.transform * p - truth * p).norm());
    return worst;
  };
  EXPECT_GT(err(even), 0.5);
  EXPECT_LT(err(weighted), 0.05 * err(even));
  EXPECT_LT(err(ignored), 1e-9);
  // The residuals are unweighted: the ignored pair shows its whole error.
  EXPECT_NEAR(ignored.residualsMm[4], std::sqrt(36.0 + 16.0 + 9.0), 1e-9);
}

TEST(PairedPoint, ReturnsARotationForMirroredPoints) {
  // A mirror image of the points: the best reflection would fit exactly; the best rotation not.
  const auto from = kneeLandmarks();
  std::vector<Eigen::Vector3d> to;
  for (const auto& p : from)
    to.push_back(Eigen::Vector3d(-p.x(), p.y(), p.z()));
  const PairedPointResult r = registerPairedPoints(from, to);
  EXPECT_NEAR(r.transform.linear().determinant(), 1.0, 1e-9);
  EXPECT_LT((r.transform.linear().transpose() * r.transform.linear() - Eigen::Matrix3d::Identity())
                .cwiseAbs()
                .maxCoeff(),
            1e-12);
  EXPECT_GT(r.freMm, 1.0);
}

TEST(PairedPoint, RefusesDataThatCannotDetermineTheTransform) {
  const auto good = kneeLandmarks();
  EXPECT_NE(thrownMessage([&] {
              registerPairedPoints({good[0], good[1]}, {good[0], good[1]});
            }).find("at least 3"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] {
              registerPairedPoints(good, {good[0], good[1], good[2]});
            }).find("4 'from' points but 3"),
            std::string::npos);
  auto bad = good;
  bad[2].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(thrownMessage([&] { registerPairedPoints(good, bad); }).find("pair 2"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] {
              registerPairedPoints(good, good, {1, -1, 1, 1});
            }).find("pair 1"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] {
              registerPairedPoints(good, good, {1, 0, 1, 0});
            }).find("2 pairs of positive weight"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] {
              registerPairedPoints(good, good, {1, 1});
            }).find("2 weights"),
            std::string::npos);
  const std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {10, 10, 10}, {25, 25, 25}, {-7, -7, -7}};
  EXPECT_NE(
      thrownMessage([&] { registerPairedPoints(line, good); }).find("'from' points are collinear"),
      std::string::npos);
  EXPECT_NE(
      thrownMessage([&] { registerPairedPoints(good, line); }).find("'to' points are collinear"),
      std::string::npos);
  // Nearly collinear but measurably not (0.5 mm off a 60 mm line) is accepted.
  auto almost = line;
  almost[1] += Eigen::Vector3d(0.5, -0.5, 0.0);
  EXPECT_NO_THROW(registerPairedPoints(almost, almost));
}

TEST(PairedPoint, ExpectedErrorsMatchMonteCarlo) {
  const Eigen::Isometry3d truth = someTransform();
  const auto fiducials = kneeLandmarks();
  const Eigen::Vector3d target(0.0, 40.0, -180.0);   // the knee, between the landmarks
  const Eigen::Vector3d farTarget(0.0, 0.0, 250.0);  // the hip, off the configuration
  const double sigma = 1.0;                          // mm per axis
  const double fle = std::sqrt(3.0) * sigma;
  double treSum = 0.0, farSum = 0.0, freSum = 0.0;
  const int trials = 4000;
  Rng rng(20260411);
  for (int t = 0; t < trials; ++t) {
    std::vector<Eigen::Vector3d> measured;
    for (const auto& p : fiducials) {
      measured.push_back(truth * p + Eigen::Vector3d(rng.normal(0, sigma), rng.normal(0, sigma),
                                                     rng.normal(0, sigma)));
    }
    const PairedPointResult r = registerPairedPoints(fiducials, measured);
    treSum += (r.transform * target - truth * target).squaredNorm();
    farSum += (r.transform * farTarget - truth * farTarget).squaredNorm();
    freSum += r.freMm * r.freMm;
  }
  const double tre = std::sqrt(treSum / trials);
  const double far = std::sqrt(farSum / trials);
  const double fre = std::sqrt(freSum / trials);
  EXPECT_NEAR(tre / expectedTargetErrorMm(fiducials, fle, target), 1.0, 0.04);
  EXPECT_NEAR(far / expectedTargetErrorMm(fiducials, fle, farTarget), 1.0, 0.04);
  EXPECT_NEAR(fre / expectedFiducialErrorMm(4, fle), 1.0, 0.04);
  EXPECT_GT(expectedTargetErrorMm(fiducials, fle, farTarget),
            1.5 * expectedTargetErrorMm(fiducials, fle, target));
  EXPECT_NE(thrownMessage([&] { expectedFiducialErrorMm(2, 1.0); }).find("at least 3"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] { expectedTargetErrorMm(fiducials, -1.0, target); }).find("FLE"),
            std::string::npos);
}

// A synthetic stylus session: rests of `restS` at each spot, moves of `moveS` between them along
// a straight line, tracker noise `noiseMm` per axis, 20 Hz, and `dropEvery`-th frames INVALID.
struct Session {
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> times;
  std::vector<bool> valid;
  std::vector<std::pair<int, int>> restFrames;  // first, last frame of each rest
};

Session makeSession(const std::vector<Eigen::Vector3d>& spots, double restS, double moveS,
                    double noiseMm, int dropEvery, std::uint64_t seed, double dt = 0.05) {
  Session s;
  Rng rng(seed);
  double t = 0.0;
  auto push = [&](const Eigen::Vector3d& p) {
    const int f = static_cast<int>(s.positions.size());
    s.positions.push_back(p + Eigen::Vector3d(rng.normal(0, noiseMm), rng.normal(0, noiseMm),
                                              rng.normal(0, noiseMm)));
    s.times.push_back(t);
    s.valid.push_back(dropEvery <= 0 || f % dropEvery != dropEvery - 1);
    t += dt;
  };
  Eigen::Vector3d here = spots[0] + Eigen::Vector3d(80, 0, 0);
  for (const auto& spot : spots) {
    const int moveFrames = static_cast<int>(moveS / dt);
    for (int i = 0; i < moveFrames; ++i) {
      push(here + (spot - here) * (static_cast<double>(i) / moveFrames));
    }
    const int first = static_cast<int>(s.positions.size());
    const int restN = static_cast<int>(restS / dt);
    for (int i = 0; i < restN; ++i)
      push(spot);
    s.restFrames.emplace_back(first, static_cast<int>(s.positions.size()) - 1);
    here = spot;
  }
  for (int i = 0; i < 20; ++i)
    push(here + Eigen::Vector3d(0, 0, 4.0 * i));  // lifted away
  return s;
}

TEST(Dwell, FindsEachRestDespiteDroppedFramesAndNoise) {
  const auto spots = kneeLandmarks();
  const Session s = makeSession(spots, 1.5, 1.0, 0.1, 7, 11);
  const std::vector<Dwell> dwells = detectDwells(s.positions, s.times, s.valid, DwellOptions{});
  ASSERT_EQ(dwells.size(), spots.size());
  for (std::size_t i = 0; i < spots.size(); ++i) {
    EXPECT_LT((dwells[i].meanMm - spots[i]).norm(), 0.1) << "dwell " << i;
    EXPECT_LT(dwells[i].spreadMm, 0.3);
    // Within a few frames of the true rest (the last moving frames are within reach).
    EXPECT_NEAR(dwells[i].firstFrame, s.restFrames[i].first, 3);
    EXPECT_NEAR(dwells[i].lastFrame, s.restFrames[i].second, 2);
    EXPECT_TRUE(s.valid[static_cast<std::size_t>(dwells[i].firstFrame)]);
  }
}

TEST(Dwell, SmoothingKeepsShortNoisyRestsWhole) {
  // The simulator's landmark capture: 100 Hz, 0.8 s rests, 0.3 mm per axis of jitter and tremor
  // (0.5 mm in 3D): single frames often leave a 1 mm ball, their 0.1 s means do not.
  const auto spots = kneeLandmarks();
  const Session s = makeSession(spots, 0.8, 1.0, 0.3, 0, 17, 0.01);
  const auto dwells = detectDwells(s.positions, s.times, s.valid, DwellOptions{});
  ASSERT_EQ(dwells.size(), spots.size());
  for (std::size_t i = 0; i < spots.size(); ++i) {
    EXPECT_LT((dwells[i].meanMm - spots[i]).norm(), 0.15) << "dwell " << i;
    EXPECT_GT(dwells[i].lastFrame - dwells[i].firstFrame, 60);
  }
  DwellOptions raw;
  raw.smoothingS = 0.0;
  EXPECT_LT(detectDwells(s.positions, s.times, s.valid, raw).size(), spots.size());
}

TEST(Dwell, IgnoresShortPausesAndSlowMotion) {
  // Pauses of 0.3 s are shorter than minDurationS: no dwell.
  const Session brief = makeSession(kneeLandmarks(), 0.3, 1.0, 0.05, 0, 3);
  EXPECT_TRUE(detectDwells(brief.positions, brief.times, brief.valid, DwellOptions{}).empty());
  // A slow drift of 0.5 mm/s is stillness for 2 s at most within 1 mm: a 4 s drift is split or
  // refused, but never averaged over more than 1 mm of travel.
  std::vector<Eigen::Vector3d> p;
  std::vector<double> t;
  for (int i = 0; i < 200; ++i) {
    t.push_back(0.02 * i);
    p.push_back(Eigen::Vector3d(0.01 * i, 0, 0));
  }
  const std::vector<bool> v(p.size(), true);
  for (const Dwell& d : detectDwells(p, t, v, DwellOptions{})) {
    EXPECT_LE(p[static_cast<std::size_t>(d.lastFrame)].x() -
                  p[static_cast<std::size_t>(d.firstFrame)].x(),
              2.0 * DwellOptions{}.maxMotionMm + 1e-9);
  }
}

TEST(Dwell, MergesARestSplitByAJitter) {
  Session s =
      makeSession({Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(50, 2, 3), Eigen::Vector3d(1, 60, 3)},
                  3.0, 1.0, 0.05, 0, 5);
  // A single 3 mm glitch in the middle of the first rest.
  const auto [first, last] = s.restFrames[0];
  s.positions[static_cast<std::size_t>((first + last) / 2)] += Eigen::Vector3d(3, 0, 0);
  const auto dwells = detectDwells(s.positions, s.times, s.valid, DwellOptions{});
  ASSERT_EQ(dwells.size(), 3u);
  EXPECT_LT((dwells[0].meanMm - Eigen::Vector3d(1, 2, 3)).norm(), 0.05);
  EXPECT_NEAR(dwells[0].firstFrame, first, 3);
  EXPECT_NEAR(dwells[0].lastFrame, last, 2);
}

TEST(Dwell, RefusesBadInput) {
  const std::vector<Eigen::Vector3d> p(20, Eigen::Vector3d::Zero());
  std::vector<double> t(20);
  for (std::size_t i = 0; i < t.size(); ++i)
    t[i] = 0.1 * static_cast<double>(i);
  const std::vector<bool> v(20, true);
  EXPECT_NE(thrownMessage([&] {
              detectDwells(p, {0.0, 1.0}, v, DwellOptions{});
            }).find("differ"),
            std::string::npos);
  DwellOptions zero;
  zero.maxMotionMm = 0.0;
  EXPECT_NE(thrownMessage([&] { detectDwells(p, t, v, zero); }).find("maxMotionMm"),
            std::string::npos);
  DwellOptions negative;
  negative.smoothingS = -0.1;
  EXPECT_NE(thrownMessage([&] { detectDwells(p, t, v, negative); }).find("smoothingS"),
            std::string::npos);
  auto back = t;
  back[7] = 0.0;
  EXPECT_NE(thrownMessage([&] { detectDwells(p, back, v, DwellOptions{}); }).find("frame 7"),
            std::string::npos);
  auto nan = p;
  nan[4].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(thrownMessage([&] { detectDwells(nan, t, v, DwellOptions{}); }).find("frame 4"),
            std::string::npos);
  // ... but a NaN in an INVALID frame is ignored.
  auto invalid = v;
  invalid[4] = false;
  EXPECT_EQ(detectDwells(nan, t, invalid, DwellOptions{}).size(), 1u);
  EXPECT_TRUE(detectDwells({}, {}, {}, DwellOptions{}).empty());
}

TEST(StylusTrack, TipInTheReferenceFrameAndRefusals) {
  Sequence capture;
  const Eigen::Isometry3d reference = someTransform();
  Eigen::Isometry3d stylus = Eigen::Isometry3d::Identity();
  stylus.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()).toRotationMatrix();
  stylus.translation() = Eigen::Vector3d(10, 20, 900);
  Eigen::Isometry3d tip = Eigen::Isometry3d::Identity();
  tip.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tip.translation() = Eigen::Vector3d(1, 2, -150);
  for (int f = 0; f < 3; ++f) {
    SequenceFrame frame;
    frame.timestampS = 10.0 + f;
    frame.transforms["ReferenceToTracker"].matrix = reference.matrix();
    frame.transforms["StylusToTracker"].matrix = stylus.matrix();
    if (f == 1)
      frame.transforms["StylusToTracker"].status = "INVALID";
    capture.frames.push_back(frame);
  }
  const StylusTrack track = stylusTipTrack(capture, tip);
  ASSERT_EQ(track.valid.size(), 3u);
  EXPECT_TRUE(track.valid[0]);
  EXPECT_FALSE(track.valid[1]);
  const Eigen::Vector3d expected = reference.inverse() * stylus * Eigen::Vector3d(1, 2, -150);
  EXPECT_LT((track.tipInReference[2] - expected).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(track.timestampsS[2], 12.0);
  EXPECT_LT((stylusTipTrack(capture, tip, "StylusToTracker", "").tipInReference[0] -
             stylus * Eigen::Vector3d(1, 2, -150))
                .norm(),
            1e-9);
  const std::string missing =
      thrownMessage([&] { stylusTipTrack(capture, tip, "StylusToTracker", "FemurToTracker"); });
  EXPECT_NE(missing.find("has no FemurToTrackerTransform"), std::string::npos) << missing;
  EXPECT_NE(missing.find("ReferenceToTrackerTransform"), std::string::npos) << missing;
  for (auto& f : capture.frames)
    f.transforms["StylusToTracker"].status = "INVALID";
  EXPECT_NE(thrownMessage([&] { stylusTipTrack(capture, tip); }).find("none of its 3 frames"),
            std::string::npos);
}

TEST(DwellMatch, SkipsRestsAwayFromTheLandmarksAndRefuses) {
  const auto landmarks = kneeLandmarks();
  const Eigen::Isometry3d truth = someTransform();
  std::vector<Dwell> dwells;
  auto add = [&](const Eigen::Vector3d& p) {
    Dwell d;
    d.meanMm = p;
    dwells.push_back(d);
  };
  add(Eigen::Vector3d(500, 0, 0));  // resting on the table before
  add(truth * landmarks[0]);
  add(truth * landmarks[1]);
  add(Eigen::Vector3d(0, 300, 20));  // put down between
  add(truth * landmarks[2]);
  add(truth * landmarks[3]);
  const DwellMatch m = matchDwellsInOrder(dwells, landmarks);
  EXPECT_EQ(m.dwellIndex, (std::vector<int>{1, 2, 4, 5}));
  EXPECT_LT(m.registration.freMm, 1e-9);
  EXPECT_EQ(m.candidates, 15);
  EXPECT_GT(m.runnerUpFreMm, 10.0);
  dwells.resize(3);
  EXPECT_NE(thrownMessage([&] {
              matchDwellsInOrder(dwells, landmarks);
            }).find("found 3 dwells of the stylus for 4 landmarks"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] {
              matchDwellsInOrder(dwells, {landmarks[0], landmarks[1]});
            }).find("2 landmarks, at least 3"),
            std::string::npos);
}

// PLUS's phantom registration: dwells on the eight landmarks of the fCal 2.0 phantom, registered
// phantom -> reference, against PLUS's own result (PhantomRegistrationLandmarkDetection).
TEST(LandmarkGolden, MatchesPlusPhantomRegistration) {
  ECHOREG_REQUIRE_SHARED_FILE(capturePath,
                              "plus/EightLandmarkPointsTrackedForPhantomRegistration.igs.mha");
  ECHOREG_REQUIRE_SHARED_FILE(configPath, "plus/PlusDeviceSet_fCal_Sim_RecordPhantomLandmarks.xml");
  ECHOREG_REQUIRE_SHARED_FILE(resultPath, "plus/PhantomRegistrationLandmarkDetection.results.xml");
  const auto landmarks = test::plusLandmarks(configPath);
  ASSERT_EQ(landmarks.size(), 8u);
  Eigen::Isometry3d tip;
  tip.matrix() = test::plusTransform(configPath, "StylusTip", "Stylus");
  Eigen::Isometry3d plus;
  plus.matrix() = test::plusTransform(resultPath, "Phantom", "Reference");

  const StylusTrack track = stylusTipTrack(readSequence(capturePath), tip);
  const std::vector<Dwell> dwells =
      detectDwells(track.tipInReference, track.timestampsS, track.valid, DwellOptions{});
  // Eight landmarks, pivoted on, plus the stylus resting away from the phantom before and after.
  ASSERT_EQ(dwells.size(), 10u);
  std::vector<Eigen::Vector3d> from;
  for (const auto& l : landmarks)
    from.push_back(l.second);
  const DwellMatch match = matchDwellsInOrder(dwells, from);
  const PairedPointResult& r = match.registration;
  EXPECT_EQ(match.dwellIndex, (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_GT(match.runnerUpFreMm, 10.0 * r.freMm);
  EXPECT_EQ(match.candidates, 45);
  const Eigen::Vector3d dt = r.transform.translation() - plus.translation();
  std::printf(
      "translation %.4f %.4f %.4f (PLUS %.4f %.4f %.4f), FRE %.4f, rotation diff %.4f deg\n",
      r.transform.translation().x(), r.transform.translation().y(), r.transform.translation().z(),
      plus.translation().x(), plus.translation().y(), plus.translation().z(), r.freMm,
      angleBetweenDeg(r.transform.linear(), plus.linear()));
  EXPECT_LT(dt.cwiseAbs().maxCoeff(), 0.3);
  EXPECT_LT(angleBetweenDeg(r.transform.linear(), plus.linear()), 0.2);
  EXPECT_LT(r.freMm, 1.0);
}

}  // namespace
}  // namespace echoreg::core
