// The pulse-echo model's wider front ends and probes: the default 8-bit record unchanged to the
// byte, the 12-bit int16 front end (left-justified codes, DC offset, slow baseline wander, a short
// ring-down burst over a tail), a 7 MHz probe's spectrum, and a whole study of a thin knee in vivo
// whose truth puts the bone 1-10 mm under the skin.
#include "echoreg/core/sequence.hpp"
#include "echoreg/simulation/pulse_echo.hpp"
#include "echoreg/simulation/study.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace echoreg::simulation {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;

// FNV-1a over the bytes of a record.
std::uint64_t fnv1a(const std::uint8_t* data, std::size_t size) {
  std::uint64_t hash = 1469598103934665603ULL;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= data[i];
    hash *= 1099511628211ULL;
  }
  return hash;
}

BeamPath gloveKnee() {
  return BeamPath{{{Tissue::Water, 9.0},
                   {Tissue::Skin, 1.5},
                   {Tissue::Fat, 5.0},
                   {Tissue::Muscle, 12.0},
                   {Tissue::CorticalBone, kInf}},
                  {20.0, 24.0}};
}

// The bare probe on a thin knee: 1.8 mm skin, a little fat and muscle, bone at 5.3 mm.
BeamPath thinKnee() {
  return BeamPath{{{Tissue::Skin, 1.8},
                   {Tissue::Fat, 0.5},
                   {Tissue::Muscle, 3.0},
                   {Tissue::CorticalBone, kInf}},
                  {}};
}

ALine simulate(const BeamPath& path, const Transducer& transducer, const Receiver& receiver,
               std::uint64_t seed) {
  core::Rng rng(seed);
  return simulateALine(path, transducer, receiver, rng);
}

TEST(FrontEnd, DefaultRecordIsByteIdenticalToBefore) {
  // FNV-1a of default 8-bit 9 MHz records, taken from the model before the front ends, the probe
  // frequency and the under-skin scale were added.
  const Transducer transducer;
  const Receiver receiver;
  const std::vector<std::pair<std::uint64_t, std::uint64_t>> expected{
      {1, 0x8d3db01a29b37c76ULL}, {42, 0x3917c526c685283dULL}, {1234, 0x25c1efb7a1da153eULL}};
  for (const auto& [seed, hash] : expected) {
    const ALine line = simulate(gloveKnee(), transducer, receiver, seed);
    EXPECT_TRUE(line.int16Samples.empty());
    EXPECT_EQ(fnv1a(line.samples.data(), line.samples.size()), hash) << "seed " << seed;
  }
}

TEST(FrontEnd, Int16CodesAreTwelveBitsLeftJustified) {
  Transducer transducer;
  Receiver receiver;
  useInt16FrontEnd(transducer, receiver, 80.0);
  const ALine line = simulate(gloveKnee(), transducer, receiver, 3);
  EXPECT_TRUE(line.samples.empty());
  ASSERT_EQ(line.int16Samples.size(), 4096U);
  int distinct = 0;
  std::vector<bool> seen(4096, false);
  for (const std::int16_t v : line.int16Samples) {
    EXPECT_EQ(v % 16, 0) << v;
    EXPECT_GE(v, -32768);
    EXPECT_LE(v, 32752);
    const auto code = static_cast<std::size_t>(v / 16 + 2048);
    if (!seen[code]) {
      seen[code] = true;
      ++distinct;
    }
  }
  EXPECT_GT(distinct, 256) << "more levels than an 8-bit card has";
  // The ring-down saturates both ends of the 12-bit range.
  const auto [lo, hi] = std::minmax_element(line.int16Samples.begin(), line.int16Samples.end());
  EXPECT_EQ(*lo, -32768);
  EXPECT_EQ(*hi, 32752);
}

TEST(FrontEnd, Int16HasADcOffsetAndASlowBaselineWander) {
  Transducer transducer;
  Receiver receiver;
  useInt16FrontEnd(transducer, receiver, 80.0);
  // The DC offset: the mean over many records of a leg (the wander's phase differs per record).
  double sum = 0.0;
  double count = 0.0;
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    const ALine line = simulate(gloveKnee(), transducer, receiver, seed);
    for (const std::int16_t v : line.int16Samples) {
      sum += v;
      count += 1.0;
    }
  }
  EXPECT_NEAR(sum / count, 80.0, 30.0);
  // The wander alone (no echo, ring-down, speckle or noise): +-1000..3000, slow.
  transducer.ringDownAmplitude = 0.0;
  transducer.ringDownTailAmplitude = 0.0;
  transducer.muscleSpeckle = 0.0;
  receiver.electronicNoiseCounts = 0.0;
  const BeamPath water{{{Tissue::Water, kInf}}, {}};
  double smallest = kInf, largest = 0.0;
  for (std::uint64_t seed = 1; seed <= 50; ++seed) {
    const ALine line = simulate(water, transducer, receiver, seed);
    const auto [lo, hi] = std::minmax_element(line.int16Samples.begin(), line.int16Samples.end());
    // At least one and a half cycles of 20 kHz in the 82 us record: both extremes are in it.
    const double peak = 0.5 * (*hi - *lo);
    smallest = std::min(smallest, peak);
    largest = std::max(largest, peak);
    EXPECT_NEAR(0.5 * (*hi + *lo), 80.0, 16.0) << "seed " << seed;
    int steepest = 0;
    for (std::size_t i = 1; i < line.int16Samples.size(); ++i)
      steepest = std::max(steepest, std::abs(line.int16Samples[i] - line.int16Samples[i - 1]));
    // 3000 x 2 pi x 200 kHz / 50 MHz = 75 per sample at most, plus one code.
    EXPECT_LE(steepest, 75 + 16) << "seed " << seed;
  }
  EXPECT_GE(smallest, 1000.0 - 16.0);
  EXPECT_LE(largest, 3000.0 + 16.0);
  EXPECT_GT(largest - smallest, 500.0) << "the wander's size varies from record to record";
}

TEST(FrontEnd, Int16RingDownBurstIsOverWithinAboutHalfAMicrosecondThenATail) {
  Transducer transducer;
  Receiver receiver;
  useInt16FrontEnd(transducer, receiver, 0.0);
  receiver.baselineWanderMin = receiver.baselineWanderMax = 0.0;
  receiver.electronicNoiseCounts = 0.0;
  transducer.muscleSpeckle = 0.0;
  const BeamPath water{{{Tissue::Water, kInf}}, {}};
  const ALine line = simulate(water, transducer, receiver, 1);
  const auto& v = line.int16Samples;
  int lastSaturated = -1;
  for (int i = 0; i < 400; ++i) {
    if (v[static_cast<std::size_t>(i)] == -32768 || v[static_cast<std::size_t>(i)] == 32752)
      lastSaturated = i;
  }
  EXPECT_GE(lastSaturated, 5);
  EXPECT_LE(lastSaturated, 30);  // 0.6 us at 50 MHz
  const auto peakOver = [&](double fromUs, double toUs) {
    int peak = 0;
    for (auto i = static_cast<std::size_t>(fromUs * 50); i < static_cast<std::size_t>(toUs * 50);
         ++i)
      peak = std::max(peak, std::abs(static_cast<int>(v[i])));
    return peak;
  };
  // The burst falls fast, the tail slowly: over 0.2 us the burst loses ~24 dB, the tail ~3.
  const double burstDrop = static_cast<double>(peakOver(0.3, 0.4)) / peakOver(0.5, 0.6);
  const double tailDrop = static_cast<double>(peakOver(1.0, 1.1)) / peakOver(1.2, 1.3);
  EXPECT_GT(burstDrop, 2.0);
  EXPECT_LT(tailDrop, 1.6);
  EXPECT_GT(tailDrop, 1.1);
  EXPECT_GT(peakOver(1.0, 1.1), 16 * 40) << "the tail is well above one code";
  EXPECT_LE(peakOver(4.0, 80.0), 16) << "and gone after a few microseconds: a code at most";
  EXPECT_GT(line.ringDownEndSample, lastSaturated);
  EXPECT_LT(line.ringDownEndSample, 200);
}

// Frequency of the largest peak (0.5-20 MHz) of the mean power spectrum of records, from the
// ring-down's end on, untapered (the echoes lie anywhere in it; the wander's leakage into the
// probe's band is tens of dB under a bone echo).
double spectrumPeakHz(const BeamPath& path, const Transducer& transducer,
                      const Receiver& receiver) {
  std::vector<double> power(391, 0.0);  // 0.5, 0.55, ... 20 MHz
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const ALine line = simulate(path, transducer, receiver, seed);
    const std::vector<std::int16_t>& v = line.int16Samples;
    const std::size_t first = static_cast<std::size_t>(line.ringDownEndSample);
    const std::size_t n = v.size() - first;
    double mean = 0.0;
    for (std::size_t i = first; i < v.size(); ++i)
      mean += v[i];
    mean /= static_cast<double>(n);
    for (std::size_t k = 0; k < power.size(); ++k) {
      const double f = (0.5 + 0.05 * static_cast<double>(k)) * 1e6;
      double re = 0.0, im = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        const double x = v[first + i] - mean;
        const double phase = 2.0 * kPi * f * static_cast<double>(i) / receiver.samplingFrequencyHz;
        re += x * std::cos(phase);
        im += x * std::sin(phase);
      }
      power[k] += re * re + im * im;
    }
  }
  const auto peak = std::max_element(power.begin(), power.end()) - power.begin();
  return (0.5 + 0.05 * static_cast<double>(peak)) * 1e6;
}

TEST(FrontEnd, SpectrumPeaksNearTheProbeFrequency) {
  for (const double fc : {7e6, 9e6}) {
    Transducer transducer;
    Receiver receiver;
    transducer.centreFrequencyHz = fc;
    useInt16FrontEnd(transducer, receiver, 80.0);
    // In water on steel: no attenuation to move the spectrum down.
    const BeamPath steel{{{Tissue::Water, 25.0}, {Tissue::Steel, kInf}}, {}};
    EXPECT_NEAR(spectrumPeakHz(steel, transducer, receiver), fc, 0.05 * fc) << fc;
    // Through a thin knee: a little lower (attenuation), still near the probe's.
    const double knee = spectrumPeakHz(thinKnee(), transducer, receiver);
    EXPECT_LE(knee, fc * 1.02) << fc;
    EXPECT_GE(knee, fc * 0.85) << fc;
  }
}

// The CSV of truth/shots.csv as rows of named fields.
std::vector<std::map<std::string, std::string>> readCsv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  {
    std::stringstream header(line);
    std::string name;
    while (std::getline(header, name, ','))
      names.push_back(name);
  }
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::string value;
    std::map<std::string, std::string> row;
    for (const std::string& name : names) {
      std::getline(fields, value, ',');
      row[name] = value;
    }
    rows.push_back(row);
  }
  return rows;
}

TEST(FrontEnd, ThinKneeInVivoStudy) {
  const test::TempDir dir;
  StudyOptions options;
  options.seed = 5;
  options.size = StudySize::Small;
  options.standoff = Standoff::None;
  options.framesPerBone = 200;
  options.underSkinScale = 0.3;
  options.probeFrequencyHz = 7e6;
  options.adc = AdcFormat::Int16Left12;
  generateStudy(options, dir.file("s"));

  // Bone 1-10 mm under the skin along the beam (the bare face presses 0.3 mm into the skin).
  const auto shots = readCsv(dir.file("s/truth/shots.csv"));
  int onBone = 0, within = 0;
  for (const auto& row : shots) {
    if (row.at("bone") == "none" || row.at("capture").find("ultrasound") == std::string::npos)
      continue;
    ++onBone;
    const double depth = std::stod(row.at("true_depth_mm"));
    if (depth >= 1.0 && depth <= 10.0)
      ++within;
  }
  ASSERT_GT(onBone, 200);
  EXPECT_EQ(within, onBone);

  // The captures: int16 12-bit codes, the probe's frequency and name in the header.
  const core::Sequence sweep = core::readSequence(dir.file("s/captures/femur_ultrasound.igs.mha"));
  EXPECT_EQ(sweep.elementType, core::ElementType::Int16);
  ASSERT_TRUE(sweep.acquisition.transducerFrequencyHz.has_value());
  EXPECT_EQ(*sweep.acquisition.transducerFrequencyHz, 7e6);
  EXPECT_NE(sweep.acquisition.transducer.find("7 MHz"), std::string::npos);
  EXPECT_EQ(sweep.acquisition.samplingFrequencyHz.value_or(0.0), 50e6);
  std::vector<std::int16_t> values(sweep.pixels.size() / 2);
  std::memcpy(values.data(), sweep.pixels.data(), values.size() * 2);
  EXPECT_TRUE(
      std::all_of(values.begin(), values.end(), [](std::int16_t v) { return v % 16 == 0; }));
  double mean = 0.0;
  for (const std::int16_t v : values)
    mean += v;
  mean /= static_cast<double>(values.size());
  EXPECT_GT(mean, 20.0) << "a DC offset of 50-110";
  EXPECT_LT(mean, 140.0);
  std::ifstream manifest(dir.file("s/study.json"));
  const nlohmann::json study = nlohmann::json::parse(manifest);
  EXPECT_EQ(study.at("generator").at("adc"), "int16-12bit");
  EXPECT_EQ(study.at("generator").at("soft_tissue_scale"), 0.3);
}

}  // namespace
}  // namespace echoreg::simulation
