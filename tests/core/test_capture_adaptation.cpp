// The default chain's measurements from the capture (transducer frequency, ring-down, shadow
// rule), its conditioning high-pass, the prominence policy's edge cases and the neighbours
// temporal filter. Records are built from explicit echoes (tests/support/aline_generator's
// makeEchoRecord) so every expectation follows from what was put in.
#include "aline_generator.hpp"

#include "echoreg/core/detection.hpp"
#include "echoreg/core/envelope.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Records of one capture: a ring-down burst at the start (the same in every record), a bone echo
// that moves, a slow baseline and a DC offset of a 12-bit left-justified digitiser.
std::vector<std::vector<float>> capture(double transducerHz, int records, double ringDownEnd,
                                        double baselineCodes) {
  test::PulseModel pulse;
  pulse.samplingFrequencyHz = 50e6;
  pulse.centreFrequencyHz = transducerHz;
  std::vector<std::vector<float>> out;
  for (int r = 0; r < records; ++r) {
    std::vector<test::EchoSpec> echoes;
    for (double s = 2.0; s < ringDownEnd; s += 4.0)
      echoes.push_back({s, 20000.0});
    echoes.push_back({400.0 + 3.0 * r, 4000.0});
    std::vector<float> x =
        test::makeEchoRecord(1500, echoes, pulse, 80.0, 30.0, static_cast<std::uint64_t>(r + 1));
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double drift =
          baselineCodes * std::sin(2.0 * kPi * 0.1e6 * static_cast<double>(i) / 50e6 + r);
      // Left-justified 12 bits: multiples of 16.
      x[i] = static_cast<float>(16.0 * std::round((x[i] + drift) / 16.0));
    }
    out.push_back(std::move(x));
  }
  return out;
}

RecordSource sourceOf(const std::vector<std::vector<float>>& records) {
  return [&records](int i, std::vector<float>& out) { out = records[static_cast<std::size_t>(i)]; };
}

TEST(CaptureAdaptation, TransducerFrequencyFromTheSpectrum) {
  for (double hz : {3.5e6, 7.2e6, 12e6}) {
    const auto records = capture(hz, 20, 0.0, 2000.0);
    const double estimate = estimateTransducerFrequencyHz(20, 1500, sourceOf(records), 50e6);
    EXPECT_NEAR(estimate, hz, 0.1 * hz) << hz;
  }
}

TEST(CaptureAdaptation, RingDownEndsWhereTheBurstDoes) {
  const auto records = capture(7e6, 40, 30.0, 0.0);
  CaptureAnalysis analysis;
  const DetectionParams params = adaptToCapture(detectionPreset("default"), 40, 1500,
                                                sourceOf(records), std::nullopt, &analysis);
  EXPECT_EQ(analysis.ringDownSource, "measured");
  // The burst's last pulse is centred at sample 26 and lasts about a pulse more; one period of
  // margin (7 samples) follows.
  EXPECT_GE(analysis.ringDownSamples, 28);
  EXPECT_LE(analysis.ringDownSamples, 60);
  EXPECT_EQ(params.peaks.ringDownEnd, analysis.ringDownSamples);
  EXPECT_EQ(analysis.transducerFrequencySource, "spectrum");
  EXPECT_NEAR(analysis.transducerFrequencyHz, 7e6, 0.7e6);
  // High-pass over 1.5 periods of half the transducer frequency, envelope over 1.25 periods.
  EXPECT_NEAR(analysis.highPassSamples, 1.5 * 50e6 / 3.5e6, 2.0);
  EXPECT_NEAR(analysis.envelopeWindowSamples, 1.25 * 50e6 / 7e6, 1.0);
}

TEST(CaptureAdaptation, NoRingDownWhenTheRecordDoesNotStartInABurst) {
  const auto records = capture(7e6, 40, 0.0, 0.0);
  CaptureAnalysis analysis;
  adaptToCapture(detectionPreset("default"), 40, 1500, sourceOf(records), std::nullopt, &analysis);
  EXPECT_EQ(analysis.ringDownSamples, 0);
}

TEST(CaptureAdaptation, GivenValuesWinAndARingDownLongerThanTheRecordIsRefused) {
  const auto records = capture(7e6, 10, 30.0, 0.0);
  DetectionParams given = detectionPreset("default");
  given.transducerFrequencyHz = 5e6;
  given.adapt.ringDown = false;
  given.envelope.ringDownSamples = 100;
  CaptureAnalysis analysis;
  const DetectionParams params = adaptToCapture(given, 10, 1500, sourceOf(records), 9e6, &analysis);
  EXPECT_EQ(analysis.transducerFrequencySource, "given");
  EXPECT_DOUBLE_EQ(analysis.transducerFrequencyHz, 5e6);
  EXPECT_EQ(params.peaks.ringDownEnd, 100);
  EXPECT_EQ(params.envelope.ringDownSamples, 0);  // the prominence policy reads through it
  DetectionParams header = detectionPreset("default");
  adaptToCapture(header, 10, 1500, sourceOf(records), 9e6, &analysis);
  EXPECT_EQ(analysis.transducerFrequencySource, "header");
  given.envelope.ringDownSamples = 1500;
  EXPECT_THROW(adaptToCapture(given, 10, 1500, sourceOf(records), std::nullopt),
               std::invalid_argument);
}

// Issue 15, item 12: an envelope window or a smoothing longer than the record is refused before
// any envelope is computed (a window of a billion samples took 24 GB); a processing window is
// clipped to the record, however far it reaches (1e9 mm was cast to an int out of its range), and
// one wholly beyond the record is refused.
TEST(CaptureAdaptation, LengthsBeyondTheRecordAreRefusedAndFarWindowsClipped) {
  const auto records = capture(7e6, 10, 30.0, 0.0);
  DetectionParams given = detectionPreset("default");
  given.depth.samplingFrequencyHz = 50e6;
  given.adapt.envelopeCycles = 0.0;
  given.envelope.windowSamples = 1000000000;
  EXPECT_THROW(adaptToCapture(given, 10, 1500, sourceOf(records), std::nullopt),
               std::invalid_argument);
  given.envelope.windowSamples = 1500;  // the whole record: allowed
  EXPECT_NO_THROW(adaptToCapture(given, 10, 1500, sourceOf(records), std::nullopt));
  DetectionParams hilbert = detectionPreset("default");
  hilbert.depth.samplingFrequencyHz = 50e6;
  hilbert.envelope.method = EnvelopeMethod::Hilbert;
  hilbert.envelope.smoothingSamples = 1501;
  EXPECT_THROW(adaptToCapture(hilbert, 10, 1500, sourceOf(records), std::nullopt),
               std::invalid_argument);

  DetectionParams far = detectionPreset("default");
  far.depth.samplingFrequencyHz = 50e6;
  far.windowMinMm = 0.0;
  far.windowMaxMm = 1e9;
  const PeakParams clipped = resolvePeakParams(far);
  EXPECT_EQ(*clipped.windowBegin, 0);
  EXPECT_GT(*clipped.windowEnd, 1500);
  // The same verdicts as without a window.
  DetectionParams none = detectionPreset("default");
  none.depth.samplingFrequencyHz = 50e6;
  const DetectionParams a = adaptToCapture(far, 10, 1500, sourceOf(records), std::nullopt);
  const DetectionParams b = adaptToCapture(none, 10, 1500, sourceOf(records), std::nullopt);
  SignalDetector withWindow(a), without(b);
  for (const auto& record : records) {
    const SignalDetection x = withWindow.detect(record.data(), 1500);
    const SignalDetection y = without.detect(record.data(), 1500);
    EXPECT_EQ(x.accepted(), y.accepted());
    EXPECT_DOUBLE_EQ(x.depthMm, y.depthMm);
  }
  far.windowMinMm = 1e9;
  far.windowMaxMm = 2e9;
  const PeakParams beyond = resolvePeakParams(far);
  EXPECT_LT(*beyond.windowBegin, *beyond.windowEnd);
  try {
    adaptToCapture(far, 10, 1500, sourceOf(records), std::nullopt);
    ADD_FAILURE() << "a window beyond the record was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("starts beyond the record"), std::string::npos)
        << e.what();
  }
}

TEST(CaptureAdaptation, HighPassRemovesTheBaselineAndKeepsTheEcho) {
  EnvelopeParams params;
  params.samplingFrequencyHz = 50e6;
  params.highPassSamples = highPassLength(3.5e6, 50e6);
  EXPECT_EQ(params.highPassSamples % 2, 1);
  EnvelopeDetector detector(params);
  const int n = 1500;
  std::vector<float> drift(n), tone(n), envelope(n);
  for (int i = 0; i < n; ++i) {
    drift[i] = static_cast<float>(100.0 + 3000.0 * std::sin(2.0 * kPi * 0.1e6 * i / 50e6));
    tone[i] = static_cast<float>(1000.0 * std::sin(2.0 * kPi * 7e6 * i / 50e6));
  }
  detector.compute(drift.data(), n, envelope.data());
  double worst = 0.0;
  for (int i = 100; i < n - 100; ++i)
    worst = std::max(worst, static_cast<double>(envelope[i]));
  EXPECT_LT(worst, 3000.0 * 0.01);  // 0.1 MHz drops by more than 40 dB
  detector.compute(tone.data(), n, envelope.data());
  double mean = 0.0;
  for (int i = 100; i < n - 100; ++i)
    mean += envelope[i];
  mean /= n - 200;
  EXPECT_NEAR(mean, 1000.0 * 2.0 / kPi, 60.0);  // |sin| averages 2/pi: 7 MHz passes
}

TEST(ProminencePolicy, AWindowEdgeOnAStrongerEchoTailIsNoEcho) {
  // A strong echo just before the window: its falling tail enters the window, which holds only
  // a weak echo. The edge sample is not a local maximum, so it is never returned.
  test::PulseModel pulse;
  const auto x = test::makeEchoRecord(4096, {{1000.0, 100.0}, {1300.0, 12.0}}, pulse, 0.0, 0.2, 1);
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Ignored;
  params.envelope.windowSamples = 7;
  params.windowMinMm = DepthConversion{}.depthMm(1004.0);
  params.windowMaxMm = DepthConversion{}.depthMm(2000.0);
  SignalDetector detector(params);
  const SignalDetection d = detector.detect(x.data(), 4096);
  ASSERT_TRUE(d.accepted()) << rejectReasonName(d.peaks.reason);
  EXPECT_NEAR(d.peaks.sampleIndex, 1300.0, 2.0);
  // window-max (calibration) takes the largest local maximum inside the window, not the edge.
  params.peaks.policy = PeakPolicy::WindowMax;
  SignalDetector windowMax(params);
  const SignalDetection w = windowMax.detect(x.data(), 4096);
  ASSERT_TRUE(w.accepted()) << rejectReasonName(w.peaks.reason);
  EXPECT_NEAR(w.peaks.sampleIndex, 1300.0, 2.0);
  // A window holding only the stronger echo's falling tail has no echo in it.
  params.windowMaxMm = DepthConversion{}.depthMm(1030.0);
  SignalDetector tailOnly(params);
  EXPECT_FALSE(tailOnly.detect(x.data(), 4096).accepted());
}

TEST(ProminencePolicy, AWindowInsideTheRingDownSaysSo) {
  test::PulseModel pulse;
  const auto x = test::makeEchoRecord(4096, {{30.0, 200.0}, {2000.0, 40.0}}, pulse, 0.0, 0.2, 1);
  DetectionParams params = detectionPreset("default");
  params.peaks.ringDownEnd = 150;
  params.windowMinMm = 0.5;
  params.windowMaxMm = 2.0;  // samples 32-130: all inside the ring-down
  SignalDetector detector(params);
  EXPECT_EQ(detector.detect(x.data(), 4096).peaks.reason, RejectReason::InRingDown);
  EXPECT_EQ(rejectReasonName(RejectReason::InRingDown), "in-ring-down");
  // A window that starts in the ring-down and reaches past it: an echo after the ring-down that
  // was judged and is not bone (a fascia with the same speckle behind it) is not-bone, not
  // in-ring-down; with nothing after the ring-down it stays in-ring-down.
  std::vector<test::EchoSpec> fascia{{30.0, 200.0}, {1000.0, 60.0}};
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> speckle(3.0, 6.0);
  for (double s = 400.0; s < 3000.0; s += 9.0)
    if (std::fabs(s - 1000.0) > 20.0)
      fascia.push_back({s, speckle(random)});
  const auto y = test::makeEchoRecord(4096, fascia, pulse, 0.0, 0.2, 5);
  params.windowMaxMm = 30.0;
  params.peaks.prominence.shadow = ShadowRule::Auto;
  SignalDetector wide(params);
  EXPECT_EQ(wide.detect(y.data(), 4096).peaks.reason, RejectReason::NotBone);
  const auto quiet = test::makeEchoRecord(4096, {{30.0, 200.0}}, pulse, 0.0, 0.2, 5);
  EXPECT_EQ(wide.detect(quiet.data(), 4096).peaks.reason, RejectReason::InRingDown);
}

TEST(ProminencePolicy, UncoupledProbeIsNotBone) {
  // Air behind the standoff: the membrane's echo comes back at half strength at twice and three
  // times its time of flight, with nothing between.
  test::PulseModel pulse;
  const auto x = test::makeEchoRecord(
      4096, {{500.0, 100.0}, {1000.0, 50.0}, {1500.0, 25.0}, {2000.0, 12.0}}, pulse, 128.0, 0.3, 2);
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Ignored;
  SignalDetector detector(params);
  EXPECT_FALSE(detector.detect(x.data(), 4096).accepted());
  // Bone in water reflects half: its second bounce is a fifth, and it is accepted.
  const auto bone =
      test::makeEchoRecord(4096, {{500.0, 100.0}, {1000.0, 20.0}}, pulse, 128.0, 0.3, 2);
  const SignalDetection d = detector.detect(bone.data(), 4096);
  ASSERT_TRUE(d.accepted()) << rejectReasonName(d.peaks.reason);
  EXPECT_NEAR(d.peaks.sampleIndex, 500.0, 2.0);
}

// Scatterers of tissue: an echo every `step` samples in [from, to), each of a random amplitude in
// [low, high).
// The default with each record judged by its own signature (the shadow rule a capture without
// shadows gets) and a ring-down over the first 100 samples.
DetectionParams perRecordRule() {
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Auto;
  params.peaks.ringDownEnd = 100;
  return params;
}

// The peak parameters of the same with the shadow required (a capture judged by the shadow).
PeakParams shadowRulePeaks() {
  DetectionParams params = perRecordRule();
  params.peaks.prominence.shadow = ShadowRule::Required;
  return resolvePeakParams(params);
}

// A hand-built envelope for the reverberation tests: tissue's speckle (800-1200) before
// `tissueEnd`, quiet (250-350) from there on.
std::vector<float> tissueThenQuiet(int count, int tissueEnd, std::mt19937_64& random) {
  std::uniform_real_distribution<double> tissue(800.0, 1200.0), quiet(250.0, 350.0);
  std::vector<float> envelope(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i)
    envelope[static_cast<std::size_t>(i)] =
        static_cast<float>(i < tissueEnd ? tissue(random) : quiet(random));
  return envelope;
}

// An echo of `height` at `at` (half a cosine, 21 samples wide) over what the envelope holds.
void paintEcho(std::vector<float>& envelope, int at, double height) {
  for (int i = at - 10; i <= at + 10; ++i)
    envelope[static_cast<std::size_t>(i)] =
        std::max(envelope[static_cast<std::size_t>(i)],
                 static_cast<float>(height * std::cos(kPi * (i - at) / 20.0)));
}

void addSpeckle(std::vector<test::EchoSpec>& echoes, double from, double to, double step,
                double low, double high, std::mt19937_64& random) {
  std::uniform_real_distribution<double> amplitude(low, high);
  for (double s = from; s < to; s += step)
    echoes.push_back({s, amplitude(random)});
}

// A hand-built envelope's knots (sample, level), joined by half cosines from each to the next.
void joinKnots(std::vector<float>& envelope, const std::vector<std::pair<int, double>>& knots) {
  for (std::size_t k = 0; k + 1 < knots.size(); ++k) {
    const auto [from, low] = knots[k];
    const auto [to, high] = knots[k + 1];
    for (int i = from; i < to; ++i) {
      const double t = static_cast<double>(i - from) / (to - from);
      envelope[static_cast<std::size_t>(i)] =
          static_cast<float>(low + (high - low) * 0.5 * (1.0 - std::cos(kPi * t)));
    }
  }
}

// Shallow bone in vivo under a fascia of similar strength: speckle from the skin, the fascia at
// 700, the bone at 900 (three quarters of it) with the cortex ringing behind it for a millimetre
// and its reverberations at 1100 and 1300. Fascia, bone and reverberations are spaced evenly
// (200 samples) with little between the first two, as an air train is; but the fascia is 700
// samples from the face and nothing lies one spacing before it, so no train can run through it.
std::vector<float> fasciaOverRingingBone(std::uint64_t seed) {
  test::PulseModel pulse;
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(seed);
  addSpeckle(echoes, 200.0, 690.0, 9.0, 2.0, 4.0, random);
  echoes.push_back({700.0, 100.0});
  addSpeckle(echoes, 710.0, 890.0, 9.0, 2.0, 4.0, random);
  echoes.push_back({900.0, 78.0});
  for (double s = 912.0; s < 980.0; s += 6.0)
    echoes.push_back({s, 45.0});
  echoes.push_back({1100.0, 45.0});
  echoes.push_back({1300.0, 28.0});
  return test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, seed);
}

TEST(ProminencePolicy, EvenlySpacedEchoesUnderTissueAreNoAirTrain) {
  DetectionParams params = perRecordRule();
  SignalDetector detector(params);
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const auto x = fasciaOverRingingBone(seed);
    const SignalDetection d = detector.detect(x.data(), 4096);
    ASSERT_TRUE(d.accepted()) << "seed " << seed << ": " << rejectReasonName(d.peaks.reason);
    EXPECT_NEAR(d.peaks.sampleIndex, 900.0, 3.0) << "seed " << seed;
  }
  // A probe ringing in air right after its ring-down: the same spacing, the bounces from the
  // face (each a round trip of the spacing after the transmit at sample 0), nothing between them.
  // Every echo of the train is air, the deeper ones too.
  test::PulseModel pulse;
  const auto air = test::makeEchoRecord(
      4096, {{200.0, 100.0}, {400.0, 70.0}, {600.0, 49.0}, {800.0, 34.0}, {1000.0, 24.0}}, pulse,
      0.0, 0.3, 3);
  params.peaks.prominence.shadow = ShadowRule::Ignored;
  SignalDetector ignored(params);
  EXPECT_FALSE(ignored.detect(air.data(), 4096).accepted());
  params.peaks.prominence.shadow = ShadowRule::Required;
  SignalDetector required(params);
  EXPECT_FALSE(required.detect(air.data(), 4096).accepted());
  // The bounce nearest the face rides on the burst's tail and can come out a little weaker than
  // the next (here 75 before 100): the train behind it is still air, and none of its bounces is
  // taken (the strongest, at 400, was).
  const auto uneven = test::makeEchoRecord(
      4096,
      {{200.0, 75.0}, {400.0, 100.0}, {600.0, 70.0}, {800.0, 49.0}, {1000.0, 34.0}, {1200.0, 24.0}},
      pulse, 0.0, 0.3, 4);
  const SignalDetection d = ignored.detect(uneven.data(), 4096);
  EXPECT_TRUE(!d.accepted() || d.peaks.sampleIndex < 250.0) << d.peaks.sampleIndex;
}

// A strong fascia at 600 over quiet tissue, bone at 1750 (three quarters of the fascia) with its
// shadow, and a weak echo deep in the shadow at 2900: spaced like a train of bounces of the
// fascia, each weaker by a similar share. But a train between the face and an interface has the
// interface's own time of flight as its spacing (or that time a multiple of it): the fascia,
// 600 samples from the transmit, cannot head a train spaced 1150. It was taken for air and the
// bone behind it rejected (the physical set's hand-held profile lost whole runs of frames so,
// stop 35).
TEST(ProminencePolicy, AnEchoNearerThanItsSpacingHeadsNoAirTrain) {
  DetectionParams params = perRecordRule();
  SignalDetector detector(params);
  test::PulseModel pulse;
  std::mt19937_64 random(35);
  std::vector<test::EchoSpec> echoes;
  addSpeckle(echoes, 150.0, 1740.0, 6.0, 4.0, 8.0, random);  // tissue
  echoes.push_back({600.0, 100.0});                          // the fascia
  echoes.push_back({1750.0, 75.0});                          // bone
  echoes.push_back({2900.0, 40.0});                          // deep in its shadow
  const auto x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, 35);
  const SignalDetection d = detector.detect(x.data(), 4096);
  ASSERT_TRUE(d.accepted()) << rejectReasonName(d.peaks.reason);
  EXPECT_NEAR(d.peaks.sampleIndex, 1750.0, 3.0);
  // The same three echoes one spacing apart from the transmit on (600, 1200, 1800: an air gap
  // behind a standoff) are air, and nothing of them is taken.
  std::vector<test::EchoSpec> train;
  addSpeckle(train, 150.0, 580.0, 6.0, 4.0, 8.0, random);
  train.push_back({600.0, 100.0});
  train.push_back({1200.0, 75.0});
  train.push_back({1800.0, 55.0});
  train.push_back({2400.0, 40.0});
  const auto y = test::makeEchoRecord(4096, train, pulse, 0.0, 0.3, 36);
  EXPECT_FALSE(detector.detect(y.data(), 4096).accepted());
}

TEST(ProminencePolicy, NothingBehindBoneIsStrongerThanBone) {
  // The skin at the end of a water standoff (600) with the bright subcutis behind it, which
  // keeps the envelope above 0.4 of the skin's echo for a millimetre as a ringing cortex does,
  // then muscle, and a fascia three times as strong as the skin at 2000 with muscle behind it
  // (no shadow). Neither is bone: the skin has a much stronger echo behind it, which bone never
  // has; the fascia has neither a shadow nor a ringing behind it.
  test::PulseModel pulse;
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(11);
  echoes.push_back({600.0, 30.0});
  addSpeckle(echoes, 608.0, 740.0, 6.0, 12.0, 18.0, random);  // the subcutis
  addSpeckle(echoes, 745.0, 3500.0, 9.0, 3.0, 6.0, random);   // muscle
  echoes.push_back({2000.0, 100.0});
  const auto x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, 11);
  DetectionParams params = perRecordRule();
  SignalDetector detector(params);
  const SignalDetection d = detector.detect(x.data(), 4096);
  EXPECT_FALSE(d.accepted()) << "accepted at sample " << d.peaks.sampleIndex;
  EXPECT_EQ(d.peaks.reason, RejectReason::NotBone);
}

// A water standoff's membrane ringing (800-910) and the skin (917), quiet fat behind them, muscle
// from 2000 and a fascia at 2970 with muscle behind it, a sixth stronger than the skin (as in the
// randomised set's fascia-as-strong captures). The skin's echo has the membrane's ringing in its
// "before" and the fat behind it: a shadow by the medians. But bone is not followed by an echo
// stronger than itself; before stop 24 only one 1.5 times stronger counted, and the skin was
// taken in all 10 records.
TEST(ProminencePolicy, AnEchoWithAStrongerOneBehindItIsNotBone) {
  test::PulseModel pulse;
  DetectionParams params = perRecordRule();
  SignalDetector detector(params);
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    std::vector<test::EchoSpec> echoes;
    std::mt19937_64 random(seed);
    addSpeckle(echoes, 800.0, 910.0, 12.0, 12.0, 20.0, random);  // the membrane ringing
    echoes.push_back({917.0, 48.0});                             // the skin
    addSpeckle(echoes, 930.0, 2000.0, 9.0, 1.0, 2.0, random);    // fat
    addSpeckle(echoes, 2000.0, 4000.0, 9.0, 2.5, 4.0, random);   // muscle
    echoes.push_back({2970.0, 56.0});                            // the fascia
    const auto x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, seed);
    const SignalDetection d = detector.detect(x.data(), 4096);
    EXPECT_FALSE(d.accepted()) << "seed " << seed << ": accepted at " << d.peaks.sampleIndex;
  }
}

// An 8-bit record: the digitiser rounds to whole codes, the noise is about a code, the tissue's
// speckle barely above it. Bone's shadow is then no quieter than the tissue's median by half, but
// as quiet as the record's quietest stretch; a fascia with the same speckle behind it is not.
std::vector<float> eightBitRecord(bool shadowBehind, std::uint64_t seed, double bone = 12.0,
                                  double speckleLow = 1.2, double speckleHigh = 2.2) {
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> speckle(speckleLow, speckleHigh);
  const double end = shadowBehind ? 2280.0 : 3400.0;
  for (double s = 1900.0; s < end; s += 9.0)
    echoes.push_back({s, speckle(random)});  // tissue, 1.5 mm before the bone
  echoes.push_back({2300.0, bone});
  std::vector<float> x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 1.0, seed);
  for (float& v : x)
    v = std::round(v);
  return x;
}

TEST(ProminencePolicy, AShadowAtTheDigitisersNoiseIsAShadow) {
  DetectionParams params = perRecordRule();
  const auto count = [](const DetectionParams& p, bool shadowBehind) {
    SignalDetector detector(p);
    int accepted = 0;
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
      const SignalDetection d = detector.detect(eightBitRecord(shadowBehind, seed).data(), 4096);
      accepted += d.accepted() && std::fabs(d.peaks.sampleIndex - 2300.0) < 5.0 ? 1 : 0;
    }
    return accepted;
  };
  EXPECT_GE(count(params, true), 13) << "bone with its shadow at the noise (15 of 20 today)";
  EXPECT_LE(count(params, false), 2) << "an echo with tissue behind it (1 of 20 today)";
  // The tissue before is less than twice the shadow: only the quiet level sees the shadow.
  params.peaks.prominence.shadowNoiseFactor = 0.0;
  EXPECT_LE(count(params, true), 3);
}

// The shadow mode (a capture where bone casts clear shadows) on such 8-bit records, the tissue a
// little brighter: bone's shadow at the noise behind an echo 16 times the noise and more than half
// the record's strongest echo is bone, though the tissue before it is less than twice the noise
// (stop 24; the specimen profile of the randomised set, seeds 13-15, missed 11.5 % of its bone
// echoes before, 3.7 % after). A weak echo behind a stronger one (here a fascia 2.5 times as
// strong) does not borrow its quiet; the trial that decides the capture's rule runs without the
// test.
TEST(ProminencePolicy, TheShadowModeSeesAShadowAtTheNoiseBehindAStrongEcho) {
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Required;
  params.peaks.ringDownEnd = 100;
  const auto count = [](const DetectionParams& p, bool shadowBehind, double strongerAbove) {
    SignalDetector detector(p);
    int accepted = 0;
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
      std::vector<float> x = eightBitRecord(shadowBehind, seed, 16.0, 2.0, 3.0);
      if (strongerAbove > 0.0) {
        test::PulseModel pulse;
        const auto fascia =
            test::makeEchoRecord(4096, {{1200.0, strongerAbove}}, pulse, 0.0, 0.0, 1);
        for (std::size_t i = 0; i < x.size(); ++i)
          x[i] = std::round(x[i] + fascia[i]);
      }
      const SignalDetection d = detector.detect(x.data(), 4096);
      accepted += d.accepted() && std::fabs(d.peaks.sampleIndex - 2300.0) < 5.0 ? 1 : 0;
    }
    return accepted;
  };
  const int withShadow = count(params, true, 0.0);
  const int withTissue = count(params, false, 0.0);
  const int underStronger = count(params, true, 40.0);
  params.peaks.prominence.noiseShadowEchoFactor = 0.0;
  const int before = count(params, true, 0.0);
  EXPECT_GE(withShadow, 12) << "of 20 (15 today)";
  EXPECT_LE(withTissue, 1) << "of 20: an echo with the tissue behind it (0 today)";
  EXPECT_LE(underStronger, 3) << "of 20: 2.5 times weaker than an echo above it";
  EXPECT_LE(before, 3) << "of 20 without the test (1 today): the tissue is under twice the noise";
  params.peaks.prominence.noiseShadowEchoFactor = 0.5;
  EXPECT_THROW(validate(params.peaks), std::invalid_argument);
}

// A short record of tissue in the shadow mode (a strapped holder: 1500 samples, bone 4.6 mm
// deep): the shadow right behind bone is the record's quietest stretch, while bone's
// reverberations and the deep tissue keep the rest of the record louder, so the record's quiet
// level is no noise floor and the tissue before bone stands less than 1.7 times above it. The
// shadow at or below 0.8 of that level counts (stop 25: the strapped-holder profile's misses
// 24.6 -> 18.7 %, seeds 1-3). A fascia over a darker layer that lasts to the end of the record
// (the level is that layer) is not taken for bone.
std::vector<float> shortTissueRecord(bool boneWithShadow, std::uint64_t seed) {
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(seed);
  addSpeckle(echoes, 10.0, 290.0, 6.0, 3.0, 9.0, random);  // tissue before
  echoes.push_back({300.0, 120.0});
  if (boneWithShadow) {
    addSpeckle(echoes, 312.0, 520.0, 6.0, 1.8, 5.4, random);   // the shadow, 0.6 x
    addSpeckle(echoes, 520.0, 1500.0, 6.0, 2.7, 8.1, random);  // reverberation, deep tissue
  } else {
    addSpeckle(echoes, 312.0, 1500.0, 6.0, 2.16, 6.48, random);  // a darker layer, 0.72 x
  }
  return test::makeEchoRecord(1500, echoes, pulse, 0.0, 1.0, seed);
}

TEST(ProminencePolicy, TheShadowModeSeesAShadowQuieterThanTheRestOfAShortRecord) {
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Required;
  params.peaks.ringDownEnd = 0;
  const auto count = [](const DetectionParams& p, bool boneWithShadow) {
    SignalDetector detector(p);
    int accepted = 0;
    for (std::uint64_t seed = 1; seed <= 40; ++seed) {
      const auto x = shortTissueRecord(boneWithShadow, seed);
      const SignalDetection d = detector.detect(x.data(), 1500);
      accepted += d.accepted() && std::fabs(d.peaks.sampleIndex - 300.0) < 5.0 ? 1 : 0;
    }
    return accepted;
  };
  const int bone = count(params, true);
  const int fascia = count(params, false);
  params.peaks.prominence.noiseShadowEchoFactor = 0.0;
  const int without = count(params, true);
  EXPECT_GE(bone, 24) << "of 40 (29 today)";
  EXPECT_LE(fascia, 5) << "of 40: a fascia over a darker layer (2 today)";
  EXPECT_LE(without, 4) << "of 40 without the noise shadow (1 today)";
}

// Under a water standoff (to 1000) the skin and the layer under it (1000-1150, loud speckle), then
// muscle to the bone at 2300 with only noise behind it. A fascia at 1240 lies under the skin: the
// region before it (3 mm, 195 samples) is two thirds skin, its median three times the muscle's,
// and the muscle behind it passed for its shadow. Twice bone's strength, the fascia was taken in
// every record (bone, under 0.6 of the strongest echo with a signature, not looked at): a physical
// set's hand-held capture lost 62 of 69 bone echoes so, and its off-bone records took the fascia.
std::vector<float> fasciaUnderTheSkin(std::uint64_t seed) {
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(seed);
  echoes.push_back({1000.0, 60.0});
  addSpeckle(echoes, 1006.0, 1150.0, 6.0, 10.0, 30.0, random);  // skin and subcutis
  addSpeckle(echoes, 1156.0, 2290.0, 6.0, 3.0, 9.0, random);    // muscle
  echoes.push_back({1240.0, 100.0});
  echoes.push_back({2300.0, 45.0});
  return test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, seed);
}

TEST(ProminencePolicy, TheShadowModeMeasuresAFasciasShadowAgainstTheTissueRightBeforeIt) {
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Required;
  params.peaks.ringDownEnd = 100;
  SignalDetector detector(params);
  int bone = 0, fascia = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const auto x = fasciaUnderTheSkin(seed);
    const SignalDetection d = detector.detect(x.data(), 4096);
    bone += d.accepted() && std::fabs(d.peaks.sampleIndex - 2300.0) < 5.0 ? 1 : 0;
    fascia += d.accepted() && std::fabs(d.peaks.sampleIndex - 1240.0) < 5.0 ? 1 : 0;
  }
  EXPECT_GE(bone, 18) << "of 20 (20 today; 0 measured against the whole region)";
  EXPECT_EQ(fascia, 0) << "of 20 (20 measured against the whole region)";
}

// A strong fascia under bright fat with dark muscle behind it (a shadow to the test), and bone 21
// mm deeper at 0.3 of its strength (oblique), its shadow behind it. The share of the strongest
// kept bone from being looked at: the fascia was taken, 21 mm off (the physical set's hand-held
// captures judged by the shadow, stop 35). Bone lies beyond the fascia's shadow region with the
// muscle's speckle before it: it is the pick. The same deep echo in the shadow of bone (noise
// before it, nothing above the quiet level) is not.
TEST(ProminencePolicy, TheShadowModeLooksAtBoneFarBehindAStrongerFascia) {
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Required;
  params.peaks.ringDownEnd = 100;
  SignalDetector detector(params);
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  int bone = 0, fascia = 0, inShadow = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    std::mt19937_64 random(seed);
    std::vector<test::EchoSpec> echoes{{600.0, 60.0}, {1240.0, 200.0}, {2600.0, 60.0}};
    addSpeckle(echoes, 606.0, 1230.0, 6.0, 20.0, 40.0, random);  // skin and fat
    addSpeckle(echoes, 1250.0, 2590.0, 6.0, 4.0, 9.0, random);   // muscle
    const auto x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, seed);
    const SignalDetection d = detector.detect(x.data(), 4096);
    bone += d.accepted() && std::fabs(d.peaks.sampleIndex - 2600.0) < 5.0 ? 1 : 0;
    fascia += d.accepted() && std::fabs(d.peaks.sampleIndex - 1240.0) < 5.0 ? 1 : 0;
    // Bone at 1240 under the same fat, nothing but noise behind it, an echo at 2600.
    std::vector<test::EchoSpec> shadowed{{600.0, 60.0}, {1240.0, 200.0}, {2600.0, 60.0}};
    addSpeckle(shadowed, 606.0, 1230.0, 6.0, 20.0, 40.0, random);
    const auto y = test::makeEchoRecord(4096, shadowed, pulse, 0.0, 0.3, seed + 100);
    const SignalDetection e = detector.detect(y.data(), 4096);
    inShadow += e.accepted() && std::fabs(e.peaks.sampleIndex - 2600.0) < 5.0 ? 1 : 0;
  }
  EXPECT_GE(bone, 18) << "of 20";
  EXPECT_EQ(fascia, 0) << "of 20";
  EXPECT_EQ(inShadow, 0) << "of 20";
}

// Bone in a water tank: one echo in the electronic noise, the water before it. The medians of
// that noise before and behind the echo differ by some per cent either way, and behind bare bone
// the cortex's inner echo and the marrow's faint scatter lift the median behind it a little over
// the water's. A shadow that had to be strictly no louder than the water was seen in 78 of the
// lone echoes' 200 records; within 1.15 times the water and 1.2 times the quiet level, 124 (stop
// 23); a strong echo (10 times the quiet level) now may have up to 1.4 times the noise behind it
// (stop 25): 178 of the lone echoes, and 162 of 200 with the marrow behind them (94 before). A
// weak echo with the same behind it is not taken for bone in water.
TEST(ProminencePolicy, BoneInWaterIsBoneWhicheverSideOfItsEchoTheNoiseIsLouder) {
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  DetectionParams params = perRecordRule();
  const auto count = [&pulse](const DetectionParams& p, double echo, bool marrow) {
    SignalDetector detector(p);
    int accepted = 0;
    int elsewhere = 0;
    for (std::uint64_t seed = 1; seed <= 200; ++seed) {
      std::vector<test::EchoSpec> echoes{{2000.0, echo}};
      if (marrow) {  // the inner cortex 1.2 mm (in water's time) behind, then the marrow
        std::mt19937_64 random(seed);
        echoes.push_back({2078.0, 0.12 * echo});
        addSpeckle(echoes, 2100.0, 4096.0, 6.0, 0.15, 0.45, random);
      }
      const auto x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 1.0, seed);
      const SignalDetection d = detector.detect(x.data(), 4096);
      if (d.accepted())
        ++(std::fabs(d.peaks.sampleIndex - 2000.0) < 3.0 ? accepted : elsewhere);
    }
    EXPECT_EQ(elsewhere, 0) << "echo " << echo << (marrow ? " with the marrow" : "");
    return accepted;
  };
  const int lone = count(params, 30.0, false);
  const int withMarrow = count(params, 30.0, true);
  const int weak = count(params, 4.0, true);
  params.peaks.prominence.noiseShadowEchoFactor = 0.0;  // before stop 25
  const int before = count(params, 30.0, true);
  EXPECT_GE(lone, 165) << "of 200";
  EXPECT_GE(withMarrow, 145) << "of 200";
  EXPECT_LE(weak, 10) << "of 200: a weak echo";
  EXPECT_LE(before, 100) << "of 200";
}

// A reflector in water that rings (PLUS's Agilent recording: a train of the plate's own echoes
// at 0.15-0.35 of the echo for 1.1-1.3 mm, each bounce weaker, then the water's noise): the
// echo at sample 2000 in water, a train of six bounces every 20 samples (0.3 mm) from 0.3 of it
// down by 0.45 each, then noise. Against it, the same echo with a layer of tissue behind it as
// long as the train (a skin behind a water standoff over 1.5 mm of tissue, then bone's shadow
// with bone's echo lost): the speckle does not decay, so it is no train.
std::vector<float> echoInWater(bool ringingTrain, std::uint64_t seed) {
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  std::vector<test::EchoSpec> echoes{{2000.0, 100.0}};
  std::mt19937_64 random(seed);
  if (ringingTrain) {
    double bounce = 30.0;
    for (int k = 1; k <= 6; ++k, bounce *= 0.45)
      echoes.push_back({2000.0 + 20.0 * k, bounce});
  } else {
    addSpeckle(echoes, 2015.0, 2120.0, 6.0, 6.0, 18.0, random);
  }
  return test::makeEchoRecord(4096, echoes, pulse, 0.0, 1.0, seed);
}

TEST(ProminencePolicy, BoneInWaterThatRingsIsBoneATissueLayerBehindAnEchoIsNoTrain) {
  // Records whose pick is the echo at 2000, and records with a pick elsewhere.
  const auto count = [](const DetectionParams& p, bool ringingTrain) {
    SignalDetector detector(p);
    std::pair<int, int> picks{0, 0};
    for (std::uint64_t seed = 1; seed <= 100; ++seed) {
      const auto x = echoInWater(ringingTrain, seed);
      const SignalDetection d = detector.detect(x.data(), 4096);
      if (d.accepted())
        ++(std::fabs(d.peaks.sampleIndex - 2000.0) < 3.0 ? picks.first : picks.second);
    }
    return picks;
  };
  for (const ShadowRule rule : {ShadowRule::Auto, ShadowRule::Required}) {
    DetectionParams params = perRecordRule();
    params.peaks.prominence.shadow = rule;
    const auto train = count(params, true);
    const auto layer = count(params, false);
    params.peaks.prominence.noiseShadowEchoFactor = 0.0;  // before: no train, no noise shadow
    const auto before = count(params, true);
    const std::string mode(shadowRuleName(rule));
    // The shadow mode judges the train over its 3 mm bone region; the per-record rule over its
    // 2 mm echo region, where this train goes quiet after two or three bounces and more than half
    // the records fail the decay test (47 of 100 taken today, 97 in the shadow mode).
    EXPECT_GE(train.first, rule == ShadowRule::Required ? 85 : 30) << "of 100, " << mode;
    EXPECT_EQ(train.second, 0) << mode << ": a bounce of the train taken";
    // (A speckle grain at the layer's end, with the quiet behind it, is taken in about a third
    // of the per-record rule's records, as before the test.)
    EXPECT_LE(layer.first, 5) << "of 100, " << mode << ": a layer of tissue behind the echo";
    EXPECT_LE(before.first, 15) << "of 100, " << mode << " without the test";
    std::cout << "[ measured ] " << mode << ": train " << train.first << ", tissue layer "
              << layer.first << " (elsewhere " << layer.second << "); without the test the echo "
              << before.first << ", a bounce " << before.second << " of 100\n";
  }
}

// Shallow bone in vivo on the ring-down's decaying tail (issue 12's recordings: the burst over by
// sample ~28, a tail over ~3 mm, bone 1-10 mm deep): speckle on a tail falling from 12 to 1.5
// times the speckle over samples 30-230, bone at sample 100 (1.5 mm) 6 times the tail there, its
// cortex ringing behind it (echoes a period apart, 7 samples, from 0.55 of it, halving every 3 mm,
// as the randomised set's in-vivo profile draws it) for 4.5 mm, then tissue. The echo stands only
// 3-5 times over the median before it (the tail), under the ringing contrast of 6. Against it, the
// same record without the bone: the strongest speckle grain on the tail is no echo.
std::vector<float> boneOnTheRingDownTail(bool bone, std::uint64_t seed) {
  test::PulseModel pulse;
  pulse.centreFrequencyHz = 7e6;
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> grain(0.5, 1.5);
  for (double s = 30.0; s < 1500.0; s += 7.0) {
    const double tail = s < 230.0 ? 12.0 * std::pow(1.5 / 12.0, (s - 30.0) / 200.0) : 1.0;
    if (!bone || s < 95.0 || s > 400.0)
      echoes.push_back({s, 3.0 * tail * grain(random)});
  }
  if (bone) {
    const double echo = 6.0 * 3.0 * 12.0 * std::pow(1.5 / 12.0, 70.0 / 200.0);
    echoes.push_back({100.0, echo});
    std::uniform_real_distribution<double> ring(0.8, 1.2);
    for (double s = 107.0; s < 400.0; s += 7.0)
      echoes.push_back({s, 0.55 * std::pow(0.5, (s - 107.0) / 195.0) * ring(random) * echo});
  }
  return test::makeEchoRecord(1500, echoes, pulse, 0.0, 0.5, seed);
}

TEST(ProminencePolicy, ShallowBoneOnTheRingDownTailRingsAsBone) {
  DetectionParams params = perRecordRule();
  params.peaks.ringDownEnd = 30;
  const auto count = [&params](bool bone) {
    SignalDetector detector(params);
    int atBone = 0, elsewhere = 0;
    for (std::uint64_t seed = 1; seed <= 100; ++seed) {
      const auto x = boneOnTheRingDownTail(bone, seed);
      const SignalDetection d = detector.detect(x.data(), 1500);
      if (d.accepted())
        ++(std::fabs(d.peaks.sampleIndex - 100.0) < 4.0 ? atBone : elsewhere);
    }
    return std::pair<int, int>{atBone, elsewhere};
  };
  const auto bone = count(true);
  const auto tissue = count(false);
  std::cout << "[ measured ] bone on the tail: " << bone.first << " at the bone, " << bone.second
            << " elsewhere; the tail without bone: " << tissue.first + tissue.second << " of 100\n";
  // 42 today, none before the dominant echo's contrast of 3; in the others the tail before the
  // echo is higher and the contrast under 3.
  EXPECT_GE(bone.first, 30) << "of 100";
  EXPECT_LE(bone.second, 5) << "of 100";
  EXPECT_LE(tissue.first + tissue.second, 5) << "of 100";
}

// Shallow bone in vivo: the skin and muscle's speckle before it, the cortex ringing behind it
// and its reverberation stepping up over the speckle as the tissue behind a wall does. A wall (the
// skin behind a water standoff) has water before it, as quiet as the record's quietest stretch;
// this echo has tissue before it, so it is bone by its ringing. Before stop 23 it was taken for
// a wall in all 10 records; a wall with water before it still is one.
std::vector<float> shallowRingingBone(bool waterBefore, std::uint64_t seed) {
  test::PulseModel pulse;
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(seed);
  if (!waterBefore)
    addSpeckle(echoes, 60.0, 990.0, 9.0, 2.0, 4.0, random);  // skin and muscle
  echoes.push_back({1000.0, 100.0});
  if (waterBefore) {
    addSpeckle(echoes, 1012.0, 3000.0, 9.0, 8.0, 12.0, random);  // the tissue behind the skin
  } else {
    addSpeckle(echoes, 1012.0, 1070.0, 6.0, 32.0, 48.0, random);  // the cortex ringing
    addSpeckle(echoes, 1070.0, 1250.0, 9.0, 8.0, 12.0, random);   // its reverberation
  }
  return test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, seed);
}

TEST(ProminencePolicy, ShallowBoneWithTissueBeforeItIsNoWall) {
  DetectionParams params = perRecordRule();
  SignalDetector detector(params);
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const SignalDetection bone = detector.detect(shallowRingingBone(false, seed).data(), 4096);
    ASSERT_TRUE(bone.accepted()) << "seed " << seed << ": " << rejectReasonName(bone.peaks.reason);
    EXPECT_NEAR(bone.peaks.sampleIndex, 1000.0, 3.0) << "seed " << seed;
    const SignalDetection wall = detector.detect(shallowRingingBone(true, seed).data(), 4096);
    EXPECT_FALSE(wall.accepted() && std::fabs(wall.peaks.sampleIndex - 1000.0) < 3.0)
        << "seed " << seed;
  }
}

// Bone at 1000 whose cortex reverberates (echoes of `reverberation` every 9 samples) for 1.5 mm,
// and whose inner surface echoes (`inner`, at 1110) behind that, the shadow after it.
std::vector<float> boneOverItsInnerCortex(double reverberation, double inner) {
  test::PulseModel pulse;
  std::vector<test::EchoSpec> echoes;
  std::mt19937_64 random(7);
  addSpeckle(echoes, 600.0, 990.0, 9.0, 3.0, 6.0, random);
  echoes.push_back({1000.0, 100.0});
  for (double s = 1010.0; s < 1100.0; s += 9.0)
    echoes.push_back({s, reverberation});
  echoes.push_back({1110.0, inner});
  return test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, 7);
}

// `params` takes bone at 1000; with the inner-echo test off, the inner echo at 1110.
void expectBoneNotItsInnerEcho(DetectionParams params, const std::vector<float>& x) {
  SignalDetector detector(params);
  const SignalDetection d = detector.detect(x.data(), 4096);
  ASSERT_TRUE(d.accepted()) << rejectReasonName(d.peaks.reason);
  EXPECT_NEAR(d.peaks.sampleIndex, 1000.0, 3.0);
  params.peaks.prominence.innerEchoRatio = 0.0;  // the test off: the inner echo
  SignalDetector without(params);
  const SignalDetection inner = without.detect(x.data(), 4096);
  ASSERT_TRUE(inner.accepted()) << rejectReasonName(inner.peaks.reason);
  EXPECT_NEAR(inner.peaks.sampleIndex, 1110.0, 3.0);
}

TEST(ProminencePolicy, TheInnerCortexBehindBoneIsNotTheBone) {
  // The cortex rings (12) and its inner surface echoes a third as strong as bone: the ringing
  // hides bone's shadow, the inner echo has one. The shadow mode's pick is then the inner echo;
  // bone is the echo above it.
  DetectionParams params = detectionPreset("default");
  params.peaks.prominence.shadow = ShadowRule::Required;
  params.peaks.ringDownEnd = 100;
  expectBoneNotItsInnerEcho(params, boneOverItsInnerCortex(12.0, 30.0));
  params.peaks.prominence.innerEchoRatio = 0.5;
  EXPECT_THROW(validate(params.peaks), std::invalid_argument);
}

TEST(ProminencePolicy, ThePerRecordRuleAlsoTakesTheBoneAboveItsInnerCortex) {
  // A weaker reverberation in the cortex (4 rather than 12), judged by the per-record rule (a
  // shadow, or the cortex ringing, behind the echo; the shadow mode's bone policy is not used):
  // the inner echo has the shadow and bone above it neither, so the rule's pick was the inner
  // echo, 1.7 mm too deep (as on the randomised set, where most echoes accepted at a wrong depth
  // lay 0.5-2 mm behind bone). The echo 2.5 times as strong (innerEchoRatio) within the bone
  // region above it is taken instead.
  const DetectionParams params = perRecordRule();
  expectBoneNotItsInnerEcho(params, boneOverItsInnerCortex(4.0, 30.0));
  // An echo only twice as strong above the pick is not enough: the pick stays.
  SignalDetector detector(params);
  const auto x = boneOverItsInnerCortex(4.0, 45.0);
  const SignalDetection weaker = detector.detect(x.data(), 4096);
  ASSERT_TRUE(weaker.accepted()) << rejectReasonName(weaker.peaks.reason);
  EXPECT_NEAR(weaker.peaks.sampleIndex, 1110.0, 3.0);
}

TEST(InterSignal, NeighboursKeepAMovingBoneAndDropALoneJump) {
  InterSignalParams params;
  params.temporal = TemporalMode::Neighbours;
  params.history = 2;
  std::vector<InterSignalInput> frames;
  // A bone rising at 40 mm/s at 100 Hz (0.4 mm per frame), one outlier, one missed frame.
  for (int f = 0; f < 20; ++f) {
    InterSignalInput in;
    in.detected = f != 12;
    in.depthMm = 10.0 + 0.4 * f + (f == 7 ? 5.0 : 0.0);
    in.pointMm = {0.0, 0.0, in.depthMm};
    in.timestampS = 0.01 * f;
    frames.push_back(in);
  }
  const std::vector<RejectReason> verdict = applyInterSignal(params, frames, false);
  for (int f = 0; f < 20; ++f) {
    if (f == 12)
      continue;
    EXPECT_EQ(verdict[static_cast<std::size_t>(f)],
              f == 7 ? RejectReason::Inconsistent : RejectReason::None)
        << "frame " << f;
  }
  // The dissertation's run filter loses most of the same sweep.
  params.temporal = TemporalMode::Run;
  params.history = 3;
  const std::vector<RejectReason> run = applyInterSignal(params, frames, false);
  int kept = 0;
  for (RejectReason r : run)
    kept += r == RejectReason::None ? 1 : 0;
  EXPECT_LT(kept, 10);
}

TEST(InterSignal, SpatialSpreadOnlyOnTrackedPoints) {
  InterSignalParams params;
  params.temporal = TemporalMode::Neighbours;
  params.history = 1;
  params.minSpreadMm = 1.0;
  std::vector<InterSignalInput> frames(5);
  for (auto& f : frames) {
    f.detected = true;
    f.depthMm = 5.0;
    f.pointMm = {0.0, 0.0, 5.0};
  }
  int kept = 0;
  for (RejectReason r : applyInterSignal(params, frames, false))
    kept += r == RejectReason::None;
  EXPECT_EQ(kept, 5);  // a transducer that does not move, no poses: nothing to spread
  kept = 0;
  for (RejectReason r : applyInterSignal(params, frames, true))
    kept += r == RejectReason::None;
  EXPECT_EQ(kept, 1);
}

TEST(Detection, BoundsOnTheAcquisitionFacts) {
  DetectionParams params = detectionPreset("default");
  params.depth.delayS = -0.001;
  EXPECT_THROW(validate(params), std::invalid_argument);
  params.depth.delayS = 1e300;
  EXPECT_THROW(validate(params), std::invalid_argument);
  params.depth.delayS = 2e-6;
  params.depth.speedOfSoundMps = 1e308;
  try {
    validate(params);
    ADD_FAILURE() << "1e308 m/s accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("speed of sound"), std::string::npos) << e.what();
  }
  // The bounds a flag and a header are held to hold for parameters set any other way (--params,
  // a manifest): once 300-6000 m/s was accepted here.
  for (double speed : {500.0, 999.0, 2001.0, 5000.0}) {
    params.depth.speedOfSoundMps = speed;
    EXPECT_THROW(validate(params), std::invalid_argument) << speed;
  }
  for (double speed : {1000.0, 1480.0, 2000.0}) {
    params.depth.speedOfSoundMps = speed;
    EXPECT_NO_THROW(validate(params)) << speed;
  }
}

// A front end's time-gain compensation (TGC) amplifies everything it receives by a gain rising
// with depth, the receiver's noise included: behind bone the shadow's noise then grows louder
// with depth than the water or tissue before the echo. Records of a phantom in water: bone's
// echo at sample 700 (10.8 mm at 50 MHz and 1540 m/s) in noise, the bounce between bone and the
// transducer's face at twice its time of flight (0.3 of it), the whole record then amplified
// by `dbPerMm` per mm of depth (a water standoff of `waterTo` samples before tissue speckle when
// given instead of bone: the level steps up once, no steady rise).
std::vector<std::vector<float>> gainedCapture(double dbPerMm, int records, int waterTo = 0) {
  test::PulseModel pulse;  // 9 MHz at 50 MHz
  const double mmPerSample = 1540.0 / 2.0 * 1000.0 / 50e6;
  std::vector<std::vector<float>> out;
  for (int r = 0; r < records; ++r) {
    std::mt19937_64 random(static_cast<std::uint64_t>(r + 1));
    std::vector<test::EchoSpec> echoes;
    if (waterTo > 0) {
      echoes.push_back({static_cast<double>(waterTo), 60.0});
      addSpeckle(echoes, waterTo + 6.0, 2000.0, 6.0, 4.0, 12.0, random);
    } else {
      const double bone = 700.0 + (r % 8);
      echoes.push_back({bone, 100.0});
      echoes.push_back({2.0 * bone, 30.0});
    }
    std::vector<float> x =
        test::makeEchoRecord(2000, echoes, pulse, 0.0, 1.0, static_cast<std::uint64_t>(r + 1));
    for (std::size_t i = 0; i < x.size(); ++i)
      x[i] *=
          static_cast<float>(std::pow(10.0, dbPerMm * mmPerSample * static_cast<double>(i) / 20.0));
    out.push_back(std::move(x));
  }
  return out;
}

TEST(CaptureAdaptation, TimeGainCompensationIsMeasuredFromTheSteadyRiseOfTheDeepNoise) {
  for (const double dbPerMm : {0.3, 0.8, 1.2}) {
    const auto records = gainedCapture(dbPerMm, 64);
    CaptureAnalysis analysis;
    const DetectionParams params = adaptToCapture(detectionPreset("default"), 64, 2000,
                                                  sourceOf(records), std::nullopt, &analysis);
    EXPECT_EQ(analysis.tgcSource, "measured") << dbPerMm;
    EXPECT_NEAR(analysis.tgcDbPerMm, dbPerMm, 0.1 * dbPerMm) << dbPerMm;
    EXPECT_NEAR(params.peaks.gainDbPerSample, analysis.tgcDbPerMm * params.peaks.mmPerSample, 1e-9);
  }
  // No gain; a water standoff giving way to tissue two thirds down the record (a step, no
  // rise); the user's word over the measurement.
  for (const int waterTo : {0, 1300}) {
    const auto records = gainedCapture(0.0, 64, waterTo);
    CaptureAnalysis analysis;
    const DetectionParams params = adaptToCapture(detectionPreset("default"), 64, 2000,
                                                  sourceOf(records), std::nullopt, &analysis);
    EXPECT_EQ(analysis.tgcSource, "none") << waterTo;
    EXPECT_EQ(params.peaks.gainDbPerSample, 0.0) << waterTo;
  }
  const auto records = gainedCapture(0.8, 64);
  DetectionParams given = detectionPreset("default");
  given.tgcDbPerMm = 0.0;
  CaptureAnalysis analysis;
  EXPECT_EQ(adaptToCapture(given, 64, 2000, sourceOf(records), std::nullopt, &analysis)
                .peaks.gainDbPerSample,
            0.0);
  EXPECT_EQ(analysis.tgcSource, "given");
  given.tgcDbPerMm = 10.5;
  EXPECT_THROW(validate(given), std::invalid_argument);
  given.tgcDbPerMm = std::nan("");
  EXPECT_THROW(validate(given), std::invalid_argument);
}

// Bone in water under TGC: the noise behind the echo is louder than the water before it by the
// gain between them, and the bounce at twice bone's time of flight is lifted by the gain over
// bone's whole depth. Judged against the noise at each region's depth and with echoes compared
// as they arrived, bone is taken; with the gain not allowed for, the noise's rise is no shadow
// and the bounce passes for an echo stronger than bone behind it.
TEST(ProminencePolicy, UnderTimeGainCompensationAShadowIsTheNoiseAtItsOwnDepth) {
  const auto records = gainedCapture(1.0, 64);
  const auto count = [&records](DetectionParams given) {
    const DetectionParams params = adaptToCapture(given, 64, 2000, sourceOf(records), std::nullopt);
    SignalDetector detector(params);
    std::pair<int, int> picks{0, 0};  // bone, anything else
    for (int r = 0; r < 64; ++r) {
      const auto& x = records[static_cast<std::size_t>(r)];
      const SignalDetection d = detector.detect(x.data(), 2000);
      if (d.accepted())
        ++(std::fabs(d.peaks.sampleIndex - (700.0 + r % 8)) < 3.0 ? picks.first : picks.second);
    }
    return picks;
  };
  const auto measured = count(detectionPreset("default"));
  DetectionParams none = detectionPreset("default");
  none.tgcDbPerMm = 0.0;
  const auto unaware = count(none);
  EXPECT_GE(measured.first, 50) << "of 64 (56 today)";
  EXPECT_EQ(measured.second, 0) << "the bounce, or noise, taken";
  EXPECT_LE(unaware.first, 6) << "of 64 with the gain not allowed for (0 today)";
}

// A probe in air, hand-held, between frames in contact: its face rings on at the digitiser's
// full scale for millimetres, far past the ring-down end the capture's median record sets (150
// here). The first peak after that end has no tissue of its own before it; it is measured
// against the ringing there, which it does not stand above, and is no bone. (Its contrast was
// taken as infinite, and the ringing behind it passed for a cortex's: the physical set's
// hand-held captures accepted 88 of 271 such frames.)
TEST(ProminencePolicy, AProbeRingingPastTheRingDownEndIsNotBone) {
  DetectionParams params = perRecordRule();
  params.peaks.ringDownEnd = 150;
  const PeakParams peaks = resolvePeakParams(params);
  const int count = 4096;
  std::vector<float> envelope(count);
  std::mt19937_64 random(37);
  std::uniform_real_distribution<double> noise(600.0, 1200.0);
  for (float& value : envelope)
    value = static_cast<float>(noise(random));
  // The burst at full scale, then saturated bounces of uneven spacing and depth between them,
  // then noise from sample 395 on.
  joinKnots(envelope,
            {{0, 33000},  {140, 33000}, {150, 12000}, {161, 33400}, {173, 4000}, {186, 31700},
             {199, 2800}, {212, 31700}, {225, 9000},  {239, 32800}, {252, 5000}, {266, 33000},
             {281, 3300}, {296, 32900}, {309, 6000},  {323, 30100}, {336, 4500}, {350, 29600},
             {362, 7000}, {375, 30600}, {395, 900}});
  const PeakResult result = findPeaks(peaks, envelope.data(), count);
  EXPECT_FALSE(result.accepted()) << "accepted at sample " << result.sampleIndex;
  EXPECT_EQ(result.reason, RejectReason::NotBone);
  // The same record in contact: bone at 1500 under tissue, its shadow behind it, is still found
  // right after such a ring-down.
  for (int i = 150; i < count; ++i)
    envelope[static_cast<std::size_t>(i)] = static_cast<float>(i < 1500 ? 3000.0 : 500.0);
  for (int i = 1485; i < 1515; ++i)
    envelope[static_cast<std::size_t>(i)] =
        static_cast<float>(3000.0 + 27000.0 * std::cos(kPi * (i - 1500) / 30.0));
  const PeakResult bone = findPeaks(peaks, envelope.data(), count);
  ASSERT_TRUE(bone.accepted()) << rejectReasonName(bone.reason);
  EXPECT_NEAR(bone.sampleIndex, 1500.0, 1.0);
}

// Under time-gain compensation (0.06 dB a sample) the noise rises with depth before and behind
// an echo just past the capture's ring-down end (150); the echo stands 20 times above the noise
// at its depth. The tissue before it is measured into the ring-down (samples 5-135), so the gain
// between that and the region behind it is taken from the centre of that range: behind the echo
// lies the noise at its depth, as quiet as the record's quietest stretch, bone whose tissue is at
// the noise. (Taken from the centre of the range clipped at the ring-down, 142 instead of 70, the
// gain was under-counted by 4.4 dB and the echo was `not-bone`.)
TEST(ProminencePolicy, AnEchoAtTheRingDownsEndIsJudgedWithTheGainWhereItsTissueWasMeasured) {
  DetectionParams params = perRecordRule();
  params.peaks.ringDownEnd = 150;
  params.peaks.gainDbPerSample = 0.06;
  const PeakParams peaks = resolvePeakParams(params);
  const int count = 500;
  const auto noise = [](double i) { return 100.0 * std::pow(10.0, 0.06 * i / 20.0); };
  std::vector<float> envelope(count);
  for (int i = 0; i < count; ++i)
    envelope[static_cast<std::size_t>(i)] = static_cast<float>(noise(i));
  for (int i = 150; i <= 170; ++i)
    envelope[static_cast<std::size_t>(i)] = static_cast<float>(
        std::max(noise(i), 20.0 * noise(160) * std::cos(kPi * (i - 160) / 20.0)));
  const PeakResult result = findPeaks(peaks, envelope.data(), count);
  ASSERT_TRUE(result.accepted()) << rejectReasonName(result.reason);
  EXPECT_NEAR(result.sampleIndex, 160.0, 1.0);
  // Without the gain the same noise is louder behind the echo than before it: no shadow.
  params.peaks.gainDbPerSample = 0.0;
  EXPECT_FALSE(findPeaks(resolvePeakParams(params), envelope.data(), count).accepted());
}

// A strapped holder's transducer off the bone, its window set from sample 800: a strong fascia
// at 600, above the window, bounces back at twice its time of flight (1200, a fifth of it), and
// behind that the record is quiet. The bounce, alone in the window with tissue before it and
// quiet behind, is no bone: its source lies above the window. Bone at 1200 as strong as the
// fascia's half or more is no bounce of it and is still found.
TEST(ProminencePolicy, AReverberationsSourceAboveTheWindowCounts) {
  DetectionParams params = perRecordRule();
  PeakParams peaks = resolvePeakParams(params);
  const int count = 2000;
  std::mt19937_64 random(39);
  std::vector<float> envelope = tissueThenQuiet(count, 1210, random);
  paintEcho(envelope, 600, 30000.0);
  paintEcho(envelope, 1200, 6000.0);
  // The whole record: the fascia is in view and its bounce is known for one.
  EXPECT_FALSE(findPeaks(peaks, envelope.data(), count).accepted());
  peaks.windowBegin = 800;
  const PeakResult bounce = findPeaks(peaks, envelope.data(), count);
  EXPECT_FALSE(bounce.accepted()) << "accepted at sample " << bounce.sampleIndex;
  EXPECT_EQ(bounce.reason, RejectReason::NotBone);
  paintEcho(envelope, 1200, 20000.0);
  const PeakResult bone = findPeaks(peaks, envelope.data(), count);
  ASSERT_TRUE(bone.accepted()) << rejectReasonName(bone.reason);
  EXPECT_NEAR(bone.sampleIndex, 1200.0, 1.0);
}

// The same fascia at 600 above a window from 800, and bone at 1216: 16 samples (three periods at
// 9 MHz and 50 MHz) off twice the fascia's time of flight, beyond the bounce tolerance of two
// periods (11 samples) that a source inside the window is held to. It is no bounce and is found; at
// 1206 it is one. (A source above the window was looked for within two periods of half the echo's
// time of flight, four periods at the bounce: bone under a fascia above the window was rejected in
// 28 frames of the physical holder's seeds 6 and 16.)
TEST(ProminencePolicy, ASourceAboveTheWindowIsTimedAsOneInsideIt) {
  DetectionParams params = perRecordRule();
  PeakParams peaks = resolvePeakParams(params);
  peaks.windowBegin = 800;
  const int count = 2000;
  std::mt19937_64 random(41);
  const auto record = [&](int bone) {
    std::vector<float> envelope = tissueThenQuiet(count, bone + 10, random);
    paintEcho(envelope, 600, 30000.0);
    paintEcho(envelope, bone, 6000.0);
    return envelope;
  };
  ASSERT_EQ(std::lround(2.0 * peaks.samplesPerCycle), 11);  // the bounce tolerance, samples
  const std::vector<float> offBounce = record(1216);
  const PeakResult bone = findPeaks(peaks, offBounce.data(), count);
  ASSERT_TRUE(bone.accepted()) << rejectReasonName(bone.reason);
  EXPECT_NEAR(bone.sampleIndex, 1216.0, 1.0);
  const std::vector<float> onBounce = record(1206);
  EXPECT_FALSE(findPeaks(peaks, onBounce.data(), count).accepted());
}

// Judged by the shadow (a capture of bone under several mm of tissue): a fascia at 600 of nearly
// full scale, the record's strongest echo, bone at 1050 under tissue, and the fascia's bounce at
// twice its time of flight (1200, a seventh of it) in bone's shadow with quiet behind it. The
// bounce is no bone, though it alone has quiet behind it (bone's shadow holds the bounce). An
// echo at twice the time of flight of a tissue echo weaker than the skin's above it is no bounce
// and is bone: a weak reflector does not bounce visibly. (Physical holder seed 4 capture 4: the
// bounce was taken for bone in 93 of 150 frames; the randomised specimen profile seed 5 capture
// 29: bone at 45.6 mm under a tissue echo at 22.7 mm, which a rule asking only a source twice
// as strong rejected.)
TEST(ProminencePolicy, ABounceInBonesShadowIsNoBone) {
  const PeakParams peaks = shadowRulePeaks();
  const int count = 2000;
  std::mt19937_64 random(40);
  std::vector<float> bounce = tissueThenQuiet(count, 1130, random);
  paintEcho(bounce, 600, 30000.0);
  paintEcho(bounce, 1050, 6000.0);
  paintEcho(bounce, 1200, 4400.0);
  const PeakResult inShadow = findPeaks(peaks, bounce.data(), count);
  EXPECT_FALSE(inShadow.accepted() && std::fabs(inShadow.sampleIndex - 1200.0) < 10.0)
      << "the bounce at 1200 taken for bone";

  std::vector<float> weakSource = tissueThenQuiet(count, 1210, random);
  paintEcho(weakSource, 300, 32000.0);  // the skin
  paintEcho(weakSource, 600, 20000.0);  // a tissue echo
  paintEcho(weakSource, 1200, 4000.0);  // bone at twice its time of flight
  const PeakResult bone = findPeaks(peaks, weakSource.data(), count);
  ASSERT_TRUE(bone.accepted()) << rejectReasonName(bone.reason);
  EXPECT_NEAR(bone.sampleIndex, 1200.0, 1.0);
}

// A record of a capture judged by the shadow (ShadowRule::Required) in which bone rings and casts
// no shadow: tissue's speckle (800-1200) from the ring-down, bone at 600 (20,000), and behind it
// the cortex's and the tissue's reverberation, 0.45 of the echo falling to 0.3 at the record's
// end. The shadow rule finds no bone in it; the record's own signature does (shallow bone in
// vivo: the in-vivo holder profile missed such records). With the shadow only, it stays refused;
// and the same ringing echo under water (quiet from the ring-down) whose envelope falls back to
// the water's level within a few millimetres is a layer in water (a phantom's soft tissue), not
// taken: the shadow rule has judged it.
TEST(ProminencePolicy, RingingBoneWithoutAShadowIsFoundUnderTheShadowRule) {
  const PeakParams peaks = shadowRulePeaks();
  const int count = 2000;
  std::mt19937_64 random(41);
  std::uniform_real_distribution<double> speckle(0.8, 1.2);
  const auto ringingBone = [&](double before, int ringingEnd) {
    std::vector<float> envelope(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) {
      const double level =
          i < 611          ? before
          : i < ringingEnd ? 20000.0 * (0.45 - 0.15 * static_cast<double>(i - 611) / (count - 611))
                           : before;
      envelope[static_cast<std::size_t>(i)] = static_cast<float>(level * speckle(random));
    }
    paintEcho(envelope, 600, 20000.0);
    return envelope;
  };
  const std::vector<float> inTissue = ringingBone(1000.0, count);
  const PeakResult bone = findPeaks(peaks, inTissue.data(), count);
  ASSERT_TRUE(bone.accepted()) << rejectReasonName(bone.reason);
  EXPECT_NEAR(bone.sampleIndex, 600.0, 2.0);

  PeakParams shadowOnly = peaks;
  shadowOnly.prominence.shadowOnly = true;
  EXPECT_FALSE(findPeaks(shadowOnly, inTissue.data(), count).accepted())
      << "a record without a shadow accepted with the shadow only";

  const std::vector<float> layerInWater = ringingBone(300.0, 800);
  const PeakResult layer = findPeaks(peaks, layerInWater.data(), count);
  EXPECT_FALSE(layer.accepted()) << "a ringing layer in water taken at " << layer.sampleIndex;
}

// Bone at 600 under tissue (1000) whose cortex echoes behind it for 60 samples (`cortex`, and
// its inner surface at 640, an eighth of bone's echo), then the shadow (300). The cortex fills
// the near half of the region behind the echo; the shadow shows over the whole region. At the
// tissue's level or under it the cortex's echoes are bone's own: a shadow. Brighter than the
// tissue before the echo, what lies behind it is more tissue: no shadow.
TEST(ProminencePolicy, BoneWhoseCortexEchoesBehindItHasAShadow) {
  const PeakParams peaks = resolvePeakParams(perRecordRule());
  const int count = 2000;
  std::mt19937_64 random(42);
  std::uniform_real_distribution<double> speckle(0.8, 1.2);
  const auto boneWithCortex = [&](double cortex) {
    std::vector<float> envelope(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) {
      const double level = i < 611 ? 1000.0 : i < 670 ? cortex : 300.0;
      envelope[static_cast<std::size_t>(i)] = static_cast<float>(level * speckle(random));
    }
    paintEcho(envelope, 600, 20000.0);
    paintEcho(envelope, 640, 2500.0);
    return envelope;
  };
  const std::vector<float> bone = boneWithCortex(800.0);
  const PeakResult found = findPeaks(peaks, bone.data(), count);
  ASSERT_TRUE(found.accepted()) << rejectReasonName(found.reason);
  EXPECT_NEAR(found.sampleIndex, 600.0, 2.0);

  const std::vector<float> tissue = boneWithCortex(1400.0);
  const PeakResult behindTissue = findPeaks(peaks, tissue.data(), count);
  EXPECT_FALSE(behindTissue.accepted()) << "taken at " << behindTissue.sampleIndex;
  EXPECT_EQ(behindTissue.reason, RejectReason::NotBone);
}

// A strong fascia at 600 whose echo bounces between it and the face (at 1200 and 1800, each
// about half the one before: a train from the face, as an air gap's), and bone at 1530 under
// the tissue, stronger than the fascia, with its shadow. Air lets nothing through, so nothing
// behind it is stronger than its echo: the fascia heads no air train and the bone is found.
// (It was rejected with every echo behind the "air": the physical hand-held set missed whole
// runs of frames so.)
TEST(ProminencePolicy, AnEchoStrongerThanATrainsHeadMakesItNoAir) {
  DetectionParams params = perRecordRule();
  SignalDetector detector(params);
  test::PulseModel pulse;
  std::mt19937_64 random(37);
  std::vector<test::EchoSpec> echoes;
  addSpeckle(echoes, 100.0, 1520.0, 6.0, 4.0, 8.0, random);  // tissue down to the bone
  echoes.push_back({600.0, 100.0});                          // the fascia
  echoes.push_back({1200.0, 48.0});                          // its bounces
  echoes.push_back({1530.0, 130.0});                         // bone
  echoes.push_back({1800.0, 25.0});
  echoes.push_back({2400.0, 13.0});
  const auto x = test::makeEchoRecord(4096, echoes, pulse, 0.0, 0.3, 38);
  const SignalDetection d = detector.detect(x.data(), 4096);
  ASSERT_TRUE(d.accepted()) << rejectReasonName(d.peaks.reason);
  EXPECT_NEAR(d.peaks.sampleIndex, 1530.0, 3.0);
}

// The skin under a water standoff, and no bone in the record: water from the ring-down to 1000,
// then the skin's layers (its first interface strongest, the envelope above 0.3 of it for
// 1.7 mm), then the tissue's speckle, four times the water, to the record's end. Behind the
// skin's first echo the envelope stays up as behind a ringing cortex, but the layers end within
// a few millimetres into tissue that steps up from the water as behind a wall: no bone. (The
// specimen captures of the randomised set took the skin for bone so, in whole captures with no
// bone in the record and in captures whose bone lay deeper.) Bone whose cortex rings on past
// that reach, water before it, is still bone.
TEST(ProminencePolicy, ASkinWhoseLayersRingIsAWall) {
  DetectionParams params = perRecordRule();
  params.peaks.ringDownEnd = 150;
  const PeakParams peaks = resolvePeakParams(params);
  const int count = 4096;
  std::vector<float> envelope(count);
  std::mt19937_64 random(38);
  std::uniform_real_distribution<double> water(400.0, 800.0), tissue(1800.0, 3600.0);
  for (int i = 0; i < count; ++i)
    envelope[static_cast<std::size_t>(i)] = static_cast<float>(i < 150    ? 30000.0
                                                               : i < 1000 ? water(random)
                                                                          : tissue(random));
  joinKnots(envelope, {{985, 600},
                       {1000, 20000},
                       {1012, 9000},
                       {1026, 15000},
                       {1040, 8000},
                       {1055, 12000},
                       {1070, 7500},
                       {1085, 10000},
                       {1100, 6000},
                       {1112, 7000},
                       {1130, 2600}});
  const PeakResult skin = findPeaks(peaks, envelope.data(), count);
  EXPECT_FALSE(skin.accepted()) << "accepted at sample " << skin.sampleIndex;
  EXPECT_EQ(skin.reason, RejectReason::NotBone);
  // Bone at 1000 in water whose cortex rings on for 5 mm, then its shadow at the water's level.
  for (int i = 1130; i < count; ++i)
    envelope[static_cast<std::size_t>(i)] = static_cast<float>(
        i < 1330 ? 7000.0 + 3000.0 * std::cos(kPi * (i - 1130) / 14.0) : water(random));
  joinKnots(envelope, {{1325, 7000}, {1345, 600}});
  const PeakResult bone = findPeaks(peaks, envelope.data(), count);
  ASSERT_TRUE(bone.accepted()) << rejectReasonName(bone.reason);
  EXPECT_NEAR(bone.sampleIndex, 1000.0, 1.0);
}

}  // namespace
}  // namespace echoreg::core
