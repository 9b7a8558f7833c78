#include "aline_generator.hpp"

#include "echoreg/core/detection.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace echoreg::core {
namespace {

std::vector<float> echoes(const std::vector<test::EchoSpec>& specs, std::uint64_t seed = 1) {
  return test::makeEchoRecord(4096, specs, test::PulseModel{}, 128.0, 0.7, seed);
}

DetectionParams chain(EnvelopeMethod method, PeakPolicy policy) {
  DetectionParams params;
  params.envelope.method = method;
  params.envelope.windowSamples = 9;
  params.envelope.zeroPhase = true;
  params.envelope.cutoffNormalized = 0.05;
  params.peaks.policy = policy;
  params.peaks.thresholdMode = ThresholdMode::FractionOfMax;
  params.peaks.thresholdOfMax = 0.3;
  return params;
}

TEST(Depth, ConversionFollowsEquation41) {
  DepthConversion depth;  // 50 MHz, no delay, 1540 m/s
  EXPECT_NEAR(depth.depthMm(1000.0), 1000.0 / 50e6 * 1540.0 * 1000.0 / 2.0, 1e-12);  // 15.4 mm
  EXPECT_NEAR(depth.mmPerSample(), 0.0154, 1e-12);
  depth.samplingFrequencyHz = 420e6;
  depth.delayS = 2e-6;
  depth.speedOfSoundMps = 1480.0;
  EXPECT_NEAR(depth.depthMm(2364.0), 5.645142857142858, 1e-9);  // PLUS's Agilent frame 0
  EXPECT_NEAR(depth.sampleIndex(depth.depthMm(1234.5)), 1234.5, 1e-9);
}

TEST(Detection, SyntheticEchoesGiveTheirDepthWithinOneSample) {
  const std::vector<double> truths{700.0, 1333.3, 2500.75, 3900.2};
  for (auto method : {EnvelopeMethod::Mozes, EnvelopeMethod::Hann, EnvelopeMethod::StdDev,
                      EnvelopeMethod::Hilbert}) {
    for (double truth : truths) {
      SignalDetector detector(chain(method, PeakPolicy::Single));
      const auto x = echoes({{truth, 80.0}});
      const SignalDetection d = detector.detect(x.data(), 4096);
      ASSERT_TRUE(d.accepted()) << envelopeMethodName(method) << " at " << truth << ": "
                                << rejectReasonName(d.peaks.reason);
      EXPECT_NEAR(d.peaks.sampleIndex, truth, 1.0) << envelopeMethodName(method);
      EXPECT_NEAR(d.depthMm, DepthConversion{}.depthMm(truth), DepthConversion{}.mmPerSample());
    }
  }
}

TEST(Detection, PoliciesPickTheRightEcho) {
  const auto x = echoes({{800.0, 40.0}, {1600.0, 90.0}, {2400.0, 60.0}});
  const auto pick = [&](PeakPolicy policy) {
    SignalDetector detector(chain(EnvelopeMethod::Hann, policy));
    return detector.detect(x.data(), 4096);
  };
  EXPECT_NEAR(pick(PeakPolicy::First).peaks.sampleIndex, 800.0, 1.0);
  EXPECT_NEAR(pick(PeakPolicy::Max).peaks.sampleIndex, 1600.0, 1.0);
  EXPECT_EQ(pick(PeakPolicy::Max).peaks.peaks.size(), 3U);

  DetectionParams windowed = chain(EnvelopeMethod::Hann, PeakPolicy::WindowMax);
  DepthConversion depth;
  windowed.windowMinMm = depth.depthMm(2000.0);
  windowed.windowMaxMm = depth.depthMm(3000.0);
  SignalDetector detector(windowed);
  EXPECT_NEAR(detector.detect(x.data(), 4096).peaks.sampleIndex, 2400.0, 1.0);

  const auto two = echoes({{900.0, 40.0}, {1900.0, 90.0}});
  SignalDetector doubleDetector(chain(EnvelopeMethod::Hann, PeakPolicy::Double));
  const SignalDetection d = doubleDetector.detect(two.data(), 4096);
  ASSERT_TRUE(d.accepted());
  EXPECT_NEAR(d.peaks.sampleIndex, 1900.0, 1.0);  // the second is bone
}

TEST(Detection, EverySingleSignalRejectionReason) {
  const auto reasonOf = [](const DetectionParams& params, const std::vector<float>& x) {
    SignalDetector detector(params);
    return detector.detect(x.data(), static_cast<int>(x.size())).peaks.reason;
  };
  // no-peak: a constant record has nothing above any threshold.
  const std::vector<float> flat(4096, 128.F);
  EXPECT_EQ(reasonOf(chain(EnvelopeMethod::Hann, PeakPolicy::Max), flat), RejectReason::NoPeak);
  // too-many-peaks / too-few-peaks.
  const auto two = echoes({{900.0, 60.0}, {1900.0, 60.0}});
  const auto one = echoes({{1900.0, 60.0}});
  EXPECT_EQ(reasonOf(chain(EnvelopeMethod::Hann, PeakPolicy::Single), two),
            RejectReason::TooManyPeaks);
  EXPECT_EQ(reasonOf(chain(EnvelopeMethod::Hann, PeakPolicy::Double), one),
            RejectReason::TooFewPeaks);
  // outside-window: the only echo lies beyond the window.
  DetectionParams windowed = chain(EnvelopeMethod::Hann, PeakPolicy::Single);
  windowed.windowMinMm = 1.0;
  windowed.windowMaxMm = 10.0;  // 650 samples; the echo is at 1900
  EXPECT_EQ(reasonOf(windowed, one), RejectReason::OutsideWindow);
  windowed.peaks.policy = PeakPolicy::WindowMax;
  EXPECT_EQ(reasonOf(windowed, one), RejectReason::OutsideWindow);
  // not-bone: an echo in water (no tissue speckle before it) is not bone.
  DetectionParams bone = detectionPreset("shadow");
  EXPECT_EQ(reasonOf(bone, one), RejectReason::NotBone);
}

TEST(Detection, BonePolicyFindsBoneBehindAStrongerFascia) {
  // Speckle from the skin (600) to the bone (1700), a fascia twice as strong as the bone at 1100,
  // then the bone's shadow.
  test::PulseModel pulse;
  std::vector<test::EchoSpec> specs{{600.0, 30.0}, {1100.0, 120.0}, {1700.0, 60.0}};
  std::mt19937_64 rng(5);
  std::normal_distribution<double> amplitude(0.0, 8.0);
  for (double s = 610.0; s < 1690.0; s += 3.0)
    specs.push_back({s, amplitude(rng)});
  const auto x = test::makeEchoRecord(4096, specs, pulse, 128.0, 0.5, 3);
  SignalDetector detector(detectionPreset("shadow"));
  const SignalDetection d = detector.detect(x.data(), 4096);
  ASSERT_TRUE(d.accepted()) << rejectReasonName(d.peaks.reason);
  EXPECT_NEAR(d.peaks.sampleIndex, 1700.0, 1.0);
  // The dissertation's policy cannot: it needs exactly two peaks.
  SignalDetector mozes(detectionPreset("mozes2008"));
  const SignalDetection m = mozes.detect(x.data(), 4096);
  EXPECT_FALSE(m.accepted() && std::fabs(m.peaks.sampleIndex - 1700.0) < 5.0);
}

// Shallow bone in vivo whose cortex rings: the echo (sample 1000, rising from the tissue's level)
// is followed, with no valley between them, by its ringing tail peaking 1.2 times higher 12
// samples later, then reverberation at 0.45 of the echo for 3 mm before the shadow. The echo is
// the bone; the tail's peak is not an echo of its own. Before the leading echo was recognised the
// tail's peak was taken (0.18 mm too deep) or the record rejected.
TEST(Detection, ProminencePolicyTakesTheEchoThatLeadsItsRingingTail) {
  std::vector<float> envelope(4096);
  for (std::size_t i = 0; i < envelope.size(); ++i)
    envelope[i] =
        1.F + 0.3F * static_cast<float>(std::pow(std::sin(0.7 * static_cast<double>(i)), 2.0));
  const float rise[] = {3.F, 8.F, 14.F, 18.F};  // samples 996-999
  for (int k = 0; k < 4; ++k)
    envelope[static_cast<std::size_t>(996 + k)] = rise[k];
  envelope[1000] = 20.F;
  for (int i = 1001; i <= 1005; ++i)  // dips to 14, no valley below half the echo
    envelope[static_cast<std::size_t>(i)] = 20.F - 1.2F * static_cast<float>(i - 1000);
  for (int i = 1006; i <= 1012; ++i)  // climbs to the tail's peak, 1.2 x the echo
    envelope[static_cast<std::size_t>(i)] = 14.F + 10.F * static_cast<float>(i - 1005) / 7.F;
  for (int i = 1013; i <= 1020; ++i)  // falls to the reverberation's level
    envelope[static_cast<std::size_t>(i)] = 24.F - 14.5F * static_cast<float>(i - 1012) / 8.F;
  for (int i = 1021; i < 1220; ++i)  // 3 mm of reverberation, then the shadow
    envelope[static_cast<std::size_t>(i)] = 9.F + 0.5F * static_cast<float>(i % 2);

  DetectionParams params = detectionPreset("default");
  params.transducerFrequencyHz = 7.5e6;
  PeakParams peaks = resolvePeakParams(params);
  peaks.ringDownEnd = 0;
  peaks.prominence.shadow = ShadowRule::Auto;
  const PeakResult result = findPeaks(peaks, envelope.data(), 4096);
  ASSERT_TRUE(result.accepted()) << rejectReasonName(result.reason);
  EXPECT_NEAR(result.sampleIndex, 1000.0, 1.0);

  // On a ramp of tissue climbing to it, the echo stands barely above what lies before it and is
  // still refused: the tail changes only the echo's prominence, not the policy's other tests.
  for (int i = 900; i < 996; ++i)
    envelope[static_cast<std::size_t>(i)] = 3.F + 0.1F * static_cast<float>(i - 900);
  const PeakResult ramp = findPeaks(peaks, envelope.data(), 4096);
  EXPECT_FALSE(ramp.accepted() && std::fabs(ramp.sampleIndex - 1000.0) < 1.0);
}

// Bone whose cortex rings on after its echo, the envelope falling to 0.4 of the echo (a valley:
// the echo keeps its prominence) but never back to the tissue before it, then climbing to a
// reverberation peak 1.1 times the echo 0.6 mm deeper (40 samples at 50 MHz), reverberation at
// 0.45 of the echo for 3 mm, the shadow. Nothing behind bone is stronger than bone, so the echo
// alone was refused for the peak behind it, and that peak was taken: 0.6 mm too deep. The peak
// rings on from the echo: the echo is the bone. With the tissue's speckle between them (a fascia
// above the bone) the deeper, stronger echo is the bone, as before. (`deeper`: the later peak.)
std::vector<float> echoThenPeak(float valley, float deeper) {
  std::vector<float> envelope(4096);
  for (std::size_t i = 0; i < envelope.size(); ++i)
    envelope[i] =
        1.F + 0.3F * static_cast<float>(std::pow(std::sin(0.7 * static_cast<double>(i)), 2.0));
  const auto set = [&](int i, float v) { envelope[static_cast<std::size_t>(i)] = v; };
  const auto ramp = [&](int from, float a, int to, float b) {  // a at from, b at to
    for (int i = from; i <= to; ++i)
      set(i, a + (b - a) * static_cast<float>(i - from) / static_cast<float>(to - from));
  };
  const float rise[] = {3.F, 8.F, 14.F, 18.F};  // samples 996-999
  for (int k = 0; k < 4; ++k)
    set(996 + k, rise[k]);
  set(1000, 20.F);
  ramp(1001, 17.F, 1010, valley);  // down to the valley
  ramp(1011, valley, 1030, valley);
  ramp(1031, valley, 1039, 0.9F * deeper);  // up to the deeper peak
  set(1040, deeper);
  ramp(1041, 0.85F * deeper, 1050, 9.F);  // down to the reverberation's level
  for (int i = 1051; i < 1250; ++i)
    set(i, 9.F + 0.5F * static_cast<float>(i % 2));
  return envelope;
}

TEST(Detection, ProminencePolicyTakesBonesEchoBeforeAStrongerPeakOfItsRinging) {
  DetectionParams params = detectionPreset("default");
  params.transducerFrequencyHz = 7.5e6;
  PeakParams peaks = resolvePeakParams(params);
  peaks.ringDownEnd = 0;
  peaks.prominence.shadow = ShadowRule::Auto;
  ASSERT_NEAR(peaks.mmPerSample, 0.0154, 1e-9);

  const std::vector<float> ringing = echoThenPeak(8.F, 22.F);
  const PeakResult result = findPeaks(peaks, ringing.data(), 4096);
  ASSERT_TRUE(result.accepted()) << rejectReasonName(result.reason);
  EXPECT_NEAR(result.sampleIndex, 1000.0, 1.0);

  const std::vector<float> fasciaThenBone = echoThenPeak(1.1F, 22.F);
  const PeakResult apart = findPeaks(peaks, fasciaThenBone.data(), 4096);
  ASSERT_TRUE(apart.accepted()) << rejectReasonName(apart.reason);
  EXPECT_NEAR(apart.sampleIndex, 1040.0, 1.0);

  // A weaker peak of the ringing (0.8 of the echo) whose valley falls under 0.3 of both but not
  // to the tissue: still the echo (a deeper echo of similar strength that stands apart is bone
  // under a fascia only when the tissue lies between them).
  const std::vector<float> weaker = echoThenPeak(3.5F, 16.F);
  const PeakResult near = findPeaks(peaks, weaker.data(), 4096);
  ASSERT_TRUE(near.accepted()) << rejectReasonName(near.reason);
  EXPECT_NEAR(near.sampleIndex, 1000.0, 1.0);
}

TEST(InterSignal, TemporalConsistencyNeedsHistoryAgreeingFrames) {
  InterSignalParams params;
  params.history = 3;
  params.consistencyMm = 0.5;
  params.minSpreadMm = 0.0;
  InterSignalFilter filter(params);
  const Eigen::Vector3d a(0, 0, 10.0), b(0, 0, 10.2), c(0, 0, 10.3), far(0, 0, 14.0);
  EXPECT_EQ(filter.judge(a), RejectReason::Inconsistent);
  EXPECT_EQ(filter.judge(b), RejectReason::Inconsistent);
  EXPECT_EQ(filter.judge(c), RejectReason::None);
  EXPECT_EQ(filter.judge(far), RejectReason::Inconsistent);  // the run restarts
  EXPECT_EQ(filter.judge(far), RejectReason::Inconsistent);
  EXPECT_EQ(filter.judge(far), RejectReason::None);
  filter.breakRun();  // a rejected frame in between
  EXPECT_EQ(filter.judge(far), RejectReason::Inconsistent);
}

TEST(InterSignal, SpatialSpreadDropsPointsTooCloseToAnAcceptedOne) {
  InterSignalParams params;
  params.history = 1;
  params.minSpreadMm = 1.0;
  InterSignalFilter filter(params);
  EXPECT_EQ(filter.judge({0, 0, 10}), RejectReason::None);
  EXPECT_EQ(filter.judge({0.5, 0.5, 10}), RejectReason::TooClose);
  EXPECT_EQ(filter.judge({1.0, 0.5, 10}), RejectReason::None);  // 1.12 mm away
  EXPECT_EQ(filter.acceptedPoints().size(), 2U);
  EXPECT_THROW(InterSignalFilter(InterSignalParams{0, 0.5, 1.0}), std::invalid_argument);
}

TEST(Detection, PresetsAndValidation) {
  for (const auto& name : detectionPresetNames())
    EXPECT_NO_THROW(validate(detectionPreset(name)));
  EXPECT_THROW(detectionPreset("fastest"), std::invalid_argument);
  DetectionParams params = detectionPreset("shadow");
  params.windowMinMm = 20.0;
  params.windowMaxMm = 10.0;
  EXPECT_THROW(validate(params), std::invalid_argument);
  params = detectionPreset("shadow");
  params.depth.speedOfSoundMps = 0.0;
  EXPECT_THROW(SignalDetector{params}, std::invalid_argument);
  EXPECT_EQ(parsePeakPolicy("window-max"), PeakPolicy::WindowMax);
  EXPECT_THROW(parsePeakPolicy("triple"), std::invalid_argument);
}

// EchoContext's inputs, made by hand: a record's verdict and its prominent echoes (a pulse: the
// run begins 3 samples before the maximum).
PeakResult recordOf(RejectReason reason, const std::vector<std::pair<int, float>>& echoes,
                    int selected = -1) {
  PeakResult result;
  result.reason = reason;
  for (const auto& [index, value] : echoes) {
    Peak peak;
    peak.index = index;
    peak.value = value;
    peak.runBegin = index - 3;
    peak.runEnd = index + 4;
    result.peaks.push_back(peak);
  }
  result.selected = selected;
  if (selected >= 0)
    result.sampleIndex = result.peaks[static_cast<std::size_t>(selected)].index;
  return result;
}

PeakParams contextParams(int frames) {
  PeakParams params;
  params.policy = PeakPolicy::Prominence;
  params.prominence.contextFrames = frames;
  params.mmPerSample = 0.015;  // 0.75 mm = 50 samples, 0.5 mm = 33
  params.samplesPerCycle = 5.0;
  params.subsample = false;
  return params;
}

// Feeds `accepted` records with bone at sample 1000 (+-2) and strength 100, then `rejected`
// not-bone ones, into `context`.
void feed(EchoContext& context, int accepted, int rejected) {
  for (int i = 0; i < accepted; ++i) {
    PeakResult r = recordOf(RejectReason::None, {{300, 60.F}, {1000 + (i % 5) - 2, 100.F}}, 1);
    EXPECT_FALSE(context.judge(r, nullptr, 0));
  }
  for (int i = 0; i < rejected; ++i) {
    PeakResult r = recordOf(RejectReason::NoPeak, {});
    EXPECT_FALSE(context.judge(r, nullptr, 0));
  }
}

TEST(EchoContext, ANotBoneRecordTakesTheEchoTheRecordsBeforeItAgreeOn) {
  EchoContext context(contextParams(10));
  feed(context, 6, 4);  // 6 of the last 10 accepted at 1000
  // A skin echo at 300 stronger than anything, and bone 20 samples (0.3 mm) deeper than before.
  PeakResult r = recordOf(RejectReason::NotBone, {{300, 200.F}, {1020, 60.F}});
  ASSERT_TRUE(context.judge(r, nullptr, 0));
  EXPECT_TRUE(r.accepted());
  EXPECT_EQ(r.selected, 1);
  EXPECT_DOUBLE_EQ(r.sampleIndex, 1020.0);
}

TEST(EchoContext, TakesNothingWithoutAnAgreeingContextOrAnEchoThere) {
  {  // 5 of 10 accepted: too few
    EchoContext context(contextParams(10));
    feed(context, 5, 5);
    PeakResult r = recordOf(RejectReason::NotBone, {{1000, 100.F}});
    EXPECT_FALSE(context.judge(r, nullptr, 0));
    EXPECT_EQ(r.reason, RejectReason::NotBone);
  }
  {  // the records before disagree: depths spread over 3 mm
    EchoContext context(contextParams(10));
    for (int i = 0; i < 10; ++i) {
      PeakResult a = recordOf(RejectReason::None, {{800 + 45 * i, 100.F}}, 0);
      context.judge(a, nullptr, 0);
    }
    PeakResult r = recordOf(RejectReason::NotBone, {{1000, 100.F}});
    EXPECT_FALSE(context.judge(r, nullptr, 0));
  }
  {  // the echo is 1 mm (67 samples) from the context's depth, or under half its strength, or
     // a slow burst, or the record was rejected for another reason than not-bone
    EchoContext context(contextParams(10));
    feed(context, 10, 0);
    PeakResult far = recordOf(RejectReason::NotBone, {{1067, 100.F}});
    EXPECT_FALSE(context.judge(far, nullptr, 0));
    feed(context, 10, 0);
    PeakResult weak = recordOf(RejectReason::NotBone, {{1000, 45.F}});
    EXPECT_FALSE(context.judge(weak, nullptr, 0));
    feed(context, 10, 0);
    PeakResult burst = recordOf(RejectReason::NotBone, {{1000, 100.F}});
    burst.peaks[0].runBegin = 1000 - 16;  // a leading edge of 3.2 periods
    EXPECT_FALSE(context.judge(burst, nullptr, 0));
    feed(context, 10, 0);
    PeakResult noisy = recordOf(RejectReason::TooManyPeaks, {{1000, 100.F}});
    EXPECT_FALSE(context.judge(noisy, nullptr, 0));
  }
  {  // a capture's first records have no context yet
    EchoContext context(contextParams(10));
    feed(context, 9, 0);
    PeakResult r = recordOf(RejectReason::NotBone, {{1000, 100.F}});
    EXPECT_FALSE(context.judge(r, nullptr, 0));
  }
}

TEST(EchoContext, OnlyRecordsAcceptedAloneMakeTheContext) {
  // Records taken from their context do not carry it on: 10 accepted alone, then not-bone
  // records with bone where the first ones had it. The 6th of these has only 5 records accepted
  // alone among its last 10; taken ones counted, every later record would be taken.
  EchoContext context(contextParams(10));
  feed(context, 10, 0);
  int taken = 0;
  for (int i = 0; i < 12; ++i) {
    PeakResult r = recordOf(RejectReason::NotBone, {{1000, 100.F}});
    taken += context.judge(r, nullptr, 0) ? 1 : 0;
  }
  EXPECT_EQ(taken, 5);
}

TEST(EchoContext, OffWithZeroFramesOrAnotherPolicy) {
  PeakParams off = contextParams(0);
  PeakParams bone = contextParams(10);
  bone.policy = PeakPolicy::Bone;
  for (const PeakParams& params : {off, bone}) {
    EchoContext context(params);
    EXPECT_FALSE(context.enabled());
    feed(context, 10, 0);
    PeakResult r = recordOf(RejectReason::NotBone, {{1000, 100.F}});
    EXPECT_FALSE(context.judge(r, nullptr, 0));
  }
  PeakParams bad = contextParams(-1);
  EXPECT_THROW(validate(bad), std::invalid_argument);
  bad.prominence.contextFrames = 1001;
  EXPECT_THROW(validate(bad), std::invalid_argument);
  EXPECT_THROW(EchoContext{bad}, std::invalid_argument);
}
}  // namespace
}  // namespace echoreg::core
