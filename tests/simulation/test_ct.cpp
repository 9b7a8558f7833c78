#include "echoreg/core/error.hpp"
#include "echoreg/simulation/ct.hpp"
#include "test_support.hpp"

#include <gdcmFile.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTag.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <stdexcept>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;

double hu(Tissue tissue) {
  return properties(tissue).hounsfield;
}

/// A leg-like phantom along z: muscle cylinder (r 40 mm) holding a cortical tube (r 10..15 mm)
/// filled with marrow, in air. Counts its calls.
class CylinderPhantom : public TissueField {
 public:
  explicit CylinderPhantom(Eigen::Vector2d centre = {0, 0}) : centre_(centre) {}
  Tissue tissueAt(const Eigen::Vector3d& p) const override {
    calls_.fetch_add(1, std::memory_order_relaxed);
    const double r = (p.head<2>() - centre_).norm();
    if (r < 10.0)
      return Tissue::Marrow;
    if (r < 15.0)
      return Tissue::CorticalBone;
    if (r < 40.0)
      return Tissue::Muscle;
    return Tissue::Air;
  }
  long calls() const { return calls_.load(); }

 private:
  Eigen::Vector2d centre_;
  mutable std::atomic<long> calls_{0};
};

/// Muscle where x < xMm (and z < zMm), air elsewhere.
class HalfSpace : public TissueField {
 public:
  HalfSpace(double xMm, double zMm) : x_(xMm), z_(zMm) {}
  Tissue tissueAt(const Eigen::Vector3d& p) const override {
    return p.x() < x_ && p.z() < z_ ? Tissue::Muscle : Tissue::Air;
  }

 private:
  double x_, z_;
};

/// One group of `slices` slices at `spacing` starting at z = 0.
CtProtocol testProtocol(int columns, int rows, double pixelMm, int slices, double spacing) {
  CtProtocol p;
  p.columns = columns;
  p.rows = rows;
  p.pixelSpacingMm = pixelMm;
  p.groups = {{"test", 0.0, (slices - 1) * spacing, spacing}};
  return p;
}

/// No texture, noise or blur: the voxel values are the partial-volume means, rounded.
CtProtocol noiseless(CtProtocol p) {
  p.noiseSigmaHu = 0.0;
  p.psfSigmaMm = 0.0;
  p.textureScale = 0.0;
  return p;
}

struct Stats {
  double mean = 0, sd = 0;
  std::size_t n = 0;
};

/// Mean and SD of the voxels whose centre radius from the z axis lies in [r0, r1).
Stats ringStats(const core::CtImage& v, double r0, double r1) {
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (int k = 0; k < v.dimensions[2]; ++k) {
    for (int j = 0; j < v.dimensions[1]; ++j) {
      for (int i = 0; i < v.dimensions[0]; ++i) {
        const double r = v.voxelCentreMm(i, j, k).head<2>().norm();
        if (r < r0 || r >= r1)
          continue;
        const double x = v.at(i, j, k);
        sum += x;
        sum2 += x * x;
        ++n;
      }
    }
  }
  Stats s;
  s.n = n;
  s.mean = sum / static_cast<double>(n);
  s.sd = std::sqrt(std::max(0.0, sum2 / static_cast<double>(n) - s.mean * s.mean));
  return s;
}

TEST(CtSynthesis, TissueMeansMatchTheTable) {
  const CtProtocol protocol = testProtocol(128, 128, 0.8, 3, 1.0);
  const CylinderPhantom phantom;
  const core::CtImage v = synthesizeCt(phantom, protocol, 7);
  ASSERT_EQ(v.hu.size(), 128u * 128u * 3u);
  struct Region {
    Tissue tissue;
    double r0, r1;
  };
  // Regions at least 1.5 mm (PSF and partial volume) from every interface.
  for (const Region& region :
       {Region{Tissue::Marrow, 0.0, 8.5}, Region{Tissue::CorticalBone, 11.5, 13.5},
        Region{Tissue::Muscle, 16.5, 38.5}, Region{Tissue::Air, 41.5, 48.0}}) {
    const Stats s = ringStats(v, region.r0, region.r1);
    const double textureSd = properties(region.tissue).hounsfieldSigma;
    const double voxelSd = std::hypot(protocol.noiseSigmaHu, textureSd);
    // Texture is correlated over ~1 mm (about 10 voxels of 0.8 mm share a value), noise is not.
    const double effectiveN = static_cast<double>(s.n) / 10.0;
    const double tolerance = 3.0 * voxelSd / std::sqrt(effectiveN) + 0.5;
    SCOPED_TRACE(properties(region.tissue).name);
    EXPECT_GT(s.n, 100u);
    EXPECT_NEAR(s.mean, hu(region.tissue), tolerance);
    // The spread is the noise and the texture (the PSF smooths the texture a little, the
    // -1024 clamp trims the air's lower tail).
    EXPECT_LT(s.sd, 1.1 * voxelSd);
    EXPECT_GT(s.sd, 0.7 * voxelSd);
  }
}

TEST(CtSynthesis, QuantumNoiseHasTheProtocolSigma) {
  // Same seed with and without noise: texture and partial volume are identical, so the difference
  // is the noise alone (plus rounding, variance 2 / 12).
  CtProtocol protocol = testProtocol(128, 128, 0.8, 2, 1.0);
  const CylinderPhantom phantom;
  const core::CtImage noisy = synthesizeCt(phantom, protocol, 3);
  protocol.noiseSigmaHu = 0.0;
  const core::CtImage clean = synthesizeCt(phantom, protocol, 3);
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (std::size_t v = 0; v < noisy.hu.size(); ++v) {
    if (clean.hu[v] < -900)
      continue;  // air is clamped at -1024
    const double d = noisy.hu[v] - clean.hu[v];
    sum += d;
    sum2 += d * d;
    ++n;
  }
  const double mean = sum / static_cast<double>(n);
  const double sd = std::sqrt(sum2 / static_cast<double>(n) - mean * mean);
  EXPECT_GT(n, 10000u);
  EXPECT_NEAR(mean, 0.0, 0.5);
  EXPECT_NEAR(sd, std::sqrt(12.0 * 12.0 + 2.0 / 12.0), 0.4);
}

TEST(CtSynthesis, TextureIsCorrelatedOverAboutOneMillimetre) {
  // Uniform muscle, texture only: SD 12 HU, autocorrelation exp(-d^2 / 1 mm^2).
  class AllMuscle : public TissueField {
   public:
    Tissue tissueAt(const Eigen::Vector3d&) const override { return Tissue::Muscle; }
  };
  CtProtocol protocol = testProtocol(200, 200, 0.5, 1, 1.0);
  protocol.noiseSigmaHu = 0.0;
  protocol.psfSigmaMm = 0.0;
  const core::CtImage v = synthesizeCt(AllMuscle(), protocol, 11);
  double sum = 0;
  for (auto x : v.hu)
    sum += x;
  const double mean = sum / static_cast<double>(v.hu.size());
  const auto correlation = [&](int lag) {
    double c = 0, var = 0;
    for (int j = 0; j < v.dimensions[1]; ++j) {
      for (int i = 0; i + lag < v.dimensions[0]; ++i) {
        const double a = v.at(i, j, 0) - mean;
        c += a * (v.at(i + lag, j, 0) - mean);
        var += a * a;
      }
    }
    return c / var;
  };
  double var = 0;
  for (auto x : v.hu)
    var += (x - mean) * (x - mean);
  const double sd = std::sqrt(var / static_cast<double>(v.hu.size()));
  EXPECT_NEAR(mean, hu(Tissue::Muscle), 1.0);
  EXPECT_NEAR(sd, properties(Tissue::Muscle).hounsfieldSigma, 1.0);
  EXPECT_NEAR(correlation(2), std::exp(-1.0), 0.06);   // 1 mm
  EXPECT_NEAR(correlation(1), std::exp(-0.25), 0.05);  // 0.5 mm
  EXPECT_LT(std::abs(correlation(6)), 0.05);           // 3 mm
}

TEST(CtSynthesis, PartialVolumeInPlaneAveragesTheSubGrid) {
  // 3 x 3 sub-samples at -1/3, 0, +1/3 of a pixel: an interface 0.1 pixel right of a voxel
  // centre leaves two thirds muscle in that voxel.
  CtProtocol protocol = noiseless(testProtocol(40, 8, 1.0, 1, 1.0));
  const core::CtImage geometry = ctGeometry(protocol);
  const int i0 = 20;
  const double xb = geometry.originMm.x() + i0 + 0.1;
  const core::CtImage v = synthesizeCt(HalfSpace(xb, 1e9), protocol, 1);
  const double mixed = (2.0 * hu(Tissue::Muscle) + hu(Tissue::Air)) / 3.0;
  for (int j = 0; j < v.dimensions[1]; ++j) {
    EXPECT_EQ(v.at(i0 - 1, j, 0), hu(Tissue::Muscle));
    EXPECT_EQ(v.at(i0, j, 0), std::floor(mixed + 0.5));
    EXPECT_EQ(v.at(i0 + 1, j, 0), hu(Tissue::Air));
  }
}

TEST(CtSynthesis, PartialVolumePreservesTheCrossSectionArea) {
  // Independent of the sub-grid layout: the muscle fraction summed over a slice of a circle in
  // air times the pixel area is the circle's area (fine sub-grid, blur conserves the sum).
  class Disc : public TissueField {
   public:
    Tissue tissueAt(const Eigen::Vector3d& p) const override {
      return (p.head<2>() - Eigen::Vector2d(0.3, -0.7)).norm() < 17.3 ? Tissue::Muscle
                                                                      : Tissue::Air;
    }
  };
  CtProtocol protocol = noiseless(testProtocol(64, 64, 0.8, 1, 1.0));
  protocol.inPlaneSupersample = 8;
  protocol.psfSigmaMm = 0.35;
  const core::CtImage v = synthesizeCt(Disc(), protocol, 1);
  double fraction = 0;
  for (auto x : v.hu)
    fraction += (x - hu(Tissue::Air)) / (hu(Tissue::Muscle) - hu(Tissue::Air));
  const double area = fraction * 0.8 * 0.8;
  EXPECT_NEAR(area, M_PI * 17.3 * 17.3, 0.002 * M_PI * 17.3 * 17.3);
}

TEST(CtSynthesis, ThickSlicesAverageThroughTheirThickness) {
  // A 5 mm slice centred on z = 0 sampled at 10 planes 0.5 mm apart (-2.25 ... 2.25): muscle below
  // z = -1.5 fills two of them.
  CtProtocol protocol = noiseless(testProtocol(16, 16, 1.0, 1, 5.0));
  const core::CtImage v = synthesizeCt(HalfSpace(1e9, -1.5), protocol, 1);
  const double expected = 0.2 * hu(Tissue::Muscle) + 0.8 * hu(Tissue::Air);
  for (auto x : v.hu)
    EXPECT_EQ(x, std::floor(expected + 0.5));
  // A 1 mm slice of the same field centred on z = 0 is all air.
  const core::CtImage thin =
      synthesizeCt(HalfSpace(1e9, -1.5), noiseless(testProtocol(16, 16, 1.0, 1, 1.0)), 1);
  for (auto x : thin.hu)
    EXPECT_EQ(x, hu(Tissue::Air));
}

TEST(CtSynthesis, PsfBlursAnEdgeLikeAGaussian) {
  // A muscle / air edge on a pixel boundary (pure voxels on both sides) blurred by sigma 0.35 mm
  // at 0.25 mm pixels. The physical image is the edge convolved with the Gaussian and averaged
  // over each pixel: the error function integrated over the pixel (closed form below). The
  // discrete blur of pixel values matches it within about 1 % of the step.
  CtProtocol protocol = noiseless(testProtocol(48, 8, 0.25, 1, 1.0));
  protocol.psfSigmaMm = 0.35;
  const core::CtImage geometry = ctGeometry(protocol);
  const double xb = geometry.originMm.x() + 23.5 * 0.25;
  const core::CtImage v = synthesizeCt(HalfSpace(xb, 1e9), protocol, 1);
  const double step = hu(Tissue::Muscle) - hu(Tissue::Air);
  const double sigma = 0.35;
  // Integral of Phi(-t / sigma) dt: F(t) = t Phi(-t/s) - s phi(t/s).
  const auto integral = [sigma](double t) {
    const double u = t / sigma;
    return t * 0.5 * std::erfc(u / std::sqrt(2.0)) -
           sigma * std::exp(-0.5 * u * u) / std::sqrt(2.0 * M_PI);
  };
  for (int i = 14; i < 34; ++i) {
    const double t = geometry.originMm.x() + i * 0.25 - xb;
    const double muscleFraction = (integral(t + 0.125) - integral(t - 0.125)) / 0.25;
    EXPECT_NEAR(v.at(i, 4, 0), hu(Tissue::Air) + step * muscleFraction, 0.012 * step)
        << "column " << i;
    // The edge is centred on xb: values mirror about it.
    EXPECT_NEAR(v.at(i, 4, 0) + v.at(47 - i, 4, 0), hu(Tissue::Air) + hu(Tissue::Muscle), 1.0);
  }
  EXPECT_EQ(v.at(10, 4, 0), hu(Tissue::Muscle));  // far from the edge: untouched
  EXPECT_EQ(v.at(37, 4, 0), hu(Tissue::Air));
}

TEST(CtSynthesis, SupersamplesOnlyNearInterfaces) {
  // 128 x 128 x 1 slice of 1 mm: 2 check planes per voxel; the sub-grid (3 x 3 x 2) only at the
  // three circles (about 3 voxels wide each), so far fewer calls than 18 per voxel.
  const CylinderPhantom phantom;
  const CtProtocol protocol = testProtocol(128, 128, 0.8, 1, 1.0);
  synthesizeCt(phantom, protocol, 1);
  const long voxels = 128 * 128;
  EXPECT_GE(phantom.calls(), 2 * voxels);
  EXPECT_LT(phantom.calls(), 4 * voxels);
}

TEST(CtSynthesis, SameSeedSameBytesOtherSeedOtherNoise) {
  const CtProtocol protocol = smallProtocol(300.0, 0.0, -350.0, {0.0, 0.0});
  const CylinderPhantom phantom;
  int calls = 0;
  double last = 0.0;
  bool increasing = true;
  const core::CtImage a = synthesizeCt(phantom, protocol, 42, [&](double fraction) {
    ++calls;
    increasing = increasing && fraction > last;
    last = fraction;
  });
  EXPECT_EQ(calls, a.dimensions[2]);
  EXPECT_TRUE(increasing);
  EXPECT_DOUBLE_EQ(last, 1.0);
  const core::CtImage b = synthesizeCt(phantom, protocol, 42);
  EXPECT_TRUE(a.hu == b.hu);
  const core::CtImage c = synthesizeCt(phantom, protocol, 43);
  std::size_t differing = 0;
  double sumDifference = 0.0;
  for (std::size_t v = 0; v < a.hu.size(); ++v) {
    differing += a.hu[v] != c.hu[v] ? 1 : 0;
    sumDifference += a.hu[v] - c.hu[v];
  }
  EXPECT_GT(differing, a.hu.size() / 2);
  EXPECT_NEAR(sumDifference / static_cast<double>(a.hu.size()), 0.0, 0.5);
}

TEST(CtSynthesis, FieldErrorsPropagate) {
  class Failing : public TissueField {
   public:
    Tissue tissueAt(const Eigen::Vector3d& p) const override {
      if (p.z() > 2.5)
        throw std::runtime_error("field failed");
      return Tissue::Water;
    }
  };
  EXPECT_THROW(synthesizeCt(Failing(), testProtocol(8, 8, 1.0, 6, 1.0), 1), std::runtime_error);
  class BadValue : public TissueField {
   public:
    Tissue tissueAt(const Eigen::Vector3d&) const override { return static_cast<Tissue>(200); }
  };
  EXPECT_THROW(synthesizeCt(BadValue(), testProtocol(8, 8, 1.0, 1, 1.0), 1), std::invalid_argument);
}

TEST(CtProtocol, GroupsGiveSlicesAtTheRightZAndThickness) {
  const CtProtocol small = smallProtocol(300.0, 0.0, -350.0, {5.0, -20.0});
  const core::CtImage v = ctGeometry(small);
  ASSERT_EQ(v.dimensions[2], 3 + 160 + 3);
  ASSERT_EQ(v.groupNames, (std::vector<std::string>{"ankle", "knee", "hip"}));
  ASSERT_EQ(v.groups.size(), 3u);
  EXPECT_EQ(v.groups[0].firstSlice, 0);
  EXPECT_EQ(v.groups[0].count, 3);
  EXPECT_DOUBLE_EQ(v.groups[0].spacingMm, 5.0);
  EXPECT_EQ(v.groups[1].firstSlice, 3);
  EXPECT_EQ(v.groups[1].count, 160);
  EXPECT_DOUBLE_EQ(v.groups[1].spacingMm, 1.0);
  EXPECT_EQ(v.groups[2].firstSlice, 163);
  EXPECT_EQ(v.groups[2].count, 3);
  EXPECT_TRUE(v.direction.isIdentity(0.0));
  EXPECT_EQ(v.dimensions[0], 256);
  EXPECT_DOUBLE_EQ(v.pixelSpacingMm.x(), 0.8);
  EXPECT_DOUBLE_EQ(v.pixelSpacingMm.y(), 0.8);
  EXPECT_NEAR(v.originMm.x(), 5.0 - 127.5 * 0.8, 1e-12);
  EXPECT_NEAR(v.originMm.y(), -20.0 - 127.5 * 0.8, 1e-12);
  for (int s = 0; s < 3; ++s) {
    EXPECT_NEAR(v.sliceLocationsMm[static_cast<std::size_t>(s)], -355.0 + 5.0 * s, 1e-9);
    EXPECT_EQ(v.sliceThicknessMm[static_cast<std::size_t>(s)], 5.0);
    EXPECT_NEAR(v.sliceLocationsMm[static_cast<std::size_t>(163 + s)], 295.0 + 5.0 * s, 1e-9);
    EXPECT_EQ(v.sliceThicknessMm[static_cast<std::size_t>(163 + s)], 5.0);
  }
  for (int s = 0; s < 160; ++s) {
    EXPECT_NEAR(v.sliceLocationsMm[static_cast<std::size_t>(3 + s)], -79.5 + s, 1e-9);
    EXPECT_EQ(v.sliceThicknessMm[static_cast<std::size_t>(3 + s)], 1.0);
  }

  // The dissertation's protocol: 10 cm at 5 mm, 2 x 10 cm at 1 mm, 10 cm at 5 mm, 0.48 mm pixels.
  const core::CtImage full = ctGeometry(dissertationProtocol(420.0, 0.0, -380.0, {0.0, 0.0}));
  EXPECT_EQ(full.dimensions[2], 240);
  EXPECT_EQ(full.dimensions[0], 512);
  EXPECT_EQ(full.dimensions[1], 512);
  EXPECT_DOUBLE_EQ(full.pixelSpacingMm.x(), 0.48);
  EXPECT_DOUBLE_EQ(full.pixelSpacingMm.y(), 0.48);
  EXPECT_NEAR(full.sliceLocationsMm.front() - 2.5, -430.0, 1e-9);  // ankle slab starts 5 cm below
  EXPECT_NEAR(full.sliceLocationsMm[20] - 0.5, -100.0, 1e-9);    // knee slab 10 cm below the joint
  EXPECT_NEAR(full.sliceLocationsMm[219] + 0.5, 100.0, 1e-9);    // and 10 cm above
  EXPECT_NEAR(full.sliceLocationsMm.back() + 2.5, 470.0, 1e-9);  // hip slab ends 5 cm above

  // Overlapping groups and bad values are refused with the value named.
  EXPECT_THROW(dissertationProtocol(120.0, 0.0, -380.0, {0.0, 0.0}), std::invalid_argument);
  CtProtocol bad = small;
  bad.pixelSpacingMm = -1.0;
  try {
    ctGeometry(bad);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pixelSpacingMm"), std::string::npos) << e.what();
  }
  bad = small;
  bad.groups[1].lastZMm += 0.5;  // not a whole number of 1 mm spacings
  EXPECT_THROW(ctGeometry(bad), std::invalid_argument);
  bad = small;
  bad.groups.clear();
  EXPECT_THROW(ctGeometry(bad), std::invalid_argument);
  bad = small;
  bad.inPlaneSupersample = 0;
  EXPECT_THROW(synthesizeCt(CylinderPhantom(), bad, 1), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// DICOM

/// A small volume with uneven slices, non-square slices and the extremes of the stored range.
core::CtImage dicomTestVolume() {
  CtProtocol protocol;
  protocol.columns = 40;
  protocol.rows = 30;
  protocol.pixelSpacingMm = 0.7;
  protocol.centreXYMm = {3.1, -12.35};
  protocol.groups = {{"knee", -1.5, 1.5, 1.0}, {"hip", 20.0, 25.0, 5.0}};
  core::CtImage v = synthesizeCt(CylinderPhantom({3.0, -12.0}), protocol, 5);
  v.hu[v.index(0, 0, 0)] = static_cast<std::int16_t>(kCtMinHu);
  v.hu[v.index(39, 29, 5)] = static_cast<std::int16_t>(kCtMaxHu);
  v.hu[v.index(39, 0, 1)] = 0;
  return v;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<double> numbers(const std::string& text) {
  std::vector<double> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, '\\'))
    out.push_back(std::stod(item));
  return out;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0'))
    s.pop_back();
  return s;
}

bool isDerivedUid(const std::string& uid) {
  if (uid.size() > 64 || uid.rfind("2.25.", 0) != 0 || uid.size() < 6)
    return false;
  const std::string digits = uid.substr(5);
  if (digits[0] == '0')
    return false;
  return std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
}

TEST(CtDicom, GdcmReadsBackExactlyWhatWasWritten) {
  const core::CtImage v = dicomTestVolume();
  const test::TempDir dir;
  const std::string folder = dir.file("ct");
  DicomSeriesInfo info;
  info.patientId = "SIM-0001";
  info.seriesDescription = "simulated leg";
  info.uidSeed = 99;
  writeDicomSeries(folder, v, info);

  std::set<std::string> instanceUids;
  std::set<std::string> studyUids, seriesUids, frameUids;
  for (int k = 0; k < v.dimensions[2]; ++k) {
    SCOPED_TRACE(k);
    char name[32];
    std::snprintf(name, sizeof name, "IM%06d.dcm", k + 1);
    gdcm::ImageReader reader;
    reader.SetFileName((folder + "/" + name).c_str());
    ASSERT_TRUE(reader.Read());
    const gdcm::Image& image = reader.GetImage();
    ASSERT_EQ(image.GetDimension(0), 40u);
    ASSERT_EQ(image.GetDimension(1), 30u);
    EXPECT_EQ(image.GetPixelFormat().GetBitsAllocated(), 16);
    EXPECT_EQ(image.GetPixelFormat().GetBitsStored(), 12);
    EXPECT_EQ(image.GetPixelFormat().GetPixelRepresentation(), 0);
    EXPECT_EQ(image.GetIntercept(), -1024.0);
    EXPECT_EQ(image.GetSlope(), 1.0);
    std::vector<char> buffer(image.GetBufferLength());
    ASSERT_EQ(buffer.size(), 40u * 30u * 2u);
    ASSERT_TRUE(image.GetBuffer(buffer.data()));
    int mismatches = 0;
    for (int j = 0; j < 30; ++j) {
      for (int i = 0; i < 40; ++i) {
        const std::size_t p = static_cast<std::size_t>(j * 40 + i) * 2;
        const int stored = static_cast<unsigned char>(buffer[p]) |
                           (static_cast<unsigned char>(buffer[p + 1]) << 8);
        mismatches += stored - 1024 != v.at(i, j, k) ? 1 : 0;
      }
    }
    EXPECT_EQ(mismatches, 0);

    gdcm::StringFilter tags;
    tags.SetFile(reader.GetFile());
    const auto tag = [&tags](std::uint16_t g, std::uint16_t e) {
      return trimmed(tags.ToString(gdcm::Tag(g, e)));
    };
    const Eigen::Vector3d first = v.voxelCentreMm(0, 0, k);
    const std::vector<double> position = numbers(tag(0x0020, 0x0032));
    ASSERT_EQ(position.size(), 3u);
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(position[static_cast<std::size_t>(a)], first[a], 1e-9);
    EXPECT_EQ(numbers(tag(0x0020, 0x0037)), (std::vector<double>{1, 0, 0, 0, 1, 0}));
    EXPECT_EQ(numbers(tag(0x0028, 0x0030)), (std::vector<double>{0.7, 0.7}));
    EXPECT_EQ(std::stod(tag(0x0018, 0x0050)), v.sliceThicknessMm[static_cast<std::size_t>(k)]);
    EXPECT_NEAR(std::stod(tag(0x0020, 0x1041)), v.sliceLocationsMm[static_cast<std::size_t>(k)],
                1e-9);
    EXPECT_EQ(std::stod(tag(0x0028, 0x1052)), -1024.0);
    EXPECT_EQ(std::stod(tag(0x0028, 0x1053)), 1.0);
    EXPECT_EQ(tag(0x0028, 0x1054), "HU");
    EXPECT_EQ(tag(0x0008, 0x0060), "CT");
    EXPECT_EQ(tag(0x0008, 0x0016), "1.2.840.10008.5.1.4.1.1.2");
    EXPECT_EQ(tag(0x0028, 0x0004), "MONOCHROME2");
    EXPECT_EQ(std::stoi(tag(0x0020, 0x0013)), k + 1);
    EXPECT_EQ(std::stoi(tag(0x0028, 0x0101)), 12);
    EXPECT_EQ(std::stoi(tag(0x0028, 0x0102)), 11);
    EXPECT_EQ(std::stod(tag(0x0018, 0x0060)), 120.0);
    EXPECT_EQ(tag(0x0010, 0x0010), "ECHOREG^SIMULATED");
    EXPECT_EQ(tag(0x0010, 0x0020), "SIM-0001");
    EXPECT_EQ(tag(0x0008, 0x0020), "20081201");
    EXPECT_EQ(std::stod(tag(0x0028, 0x1050)), 400.0);
    EXPECT_EQ(std::stod(tag(0x0028, 0x1051)), 1800.0);
    EXPECT_EQ(reader.GetFile().GetHeader().GetDataSetTransferSyntax(),
              gdcm::TransferSyntax::ExplicitVRLittleEndian);
    for (const std::string& uid :
         {tag(0x0008, 0x0018), tag(0x0020, 0x000d), tag(0x0020, 0x000e), tag(0x0020, 0x0052)}) {
      EXPECT_TRUE(isDerivedUid(uid)) << uid;
    }
    instanceUids.insert(tag(0x0008, 0x0018));
    studyUids.insert(tag(0x0020, 0x000d));
    seriesUids.insert(tag(0x0020, 0x000e));
    frameUids.insert(tag(0x0020, 0x0052));
  }
  EXPECT_EQ(instanceUids.size(), static_cast<std::size_t>(v.dimensions[2]));
  ASSERT_EQ(studyUids.size(), 1u);
  ASSERT_EQ(seriesUids.size(), 1u);
  ASSERT_EQ(frameUids.size(), 1u);
  std::set<std::string> all = instanceUids;
  all.insert(*studyUids.begin());
  all.insert(*seriesUids.begin());
  all.insert(*frameUids.begin());
  EXPECT_EQ(all.size(), static_cast<std::size_t>(v.dimensions[2]) + 3);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1)
      << "no temporary folder left beside the series";
}

TEST(CtDicom, SameUidSeedSameBytes) {
  const core::CtImage v = dicomTestVolume();
  const test::TempDir dir;
  DicomSeriesInfo info;
  info.uidSeed = 7;
  writeDicomSeries(dir.file("a"), v, info);
  writeDicomSeries(dir.file("b"), v, info);
  info.uidSeed = 8;
  writeDicomSeries(dir.file("c"), v, info);
  for (int k = 1; k <= v.dimensions[2]; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "/IM%06d.dcm", k);
    const std::string a = readBytes(dir.file("a") + name);
    EXPECT_GT(a.size(), 40u * 30u * 2u);
    EXPECT_EQ(a, readBytes(dir.file("b") + name)) << name;
    EXPECT_NE(a, readBytes(dir.file("c") + name)) << name;
  }
  EXPECT_NE(derivedDicomUid(7, "study"), derivedDicomUid(8, "study"));
  EXPECT_NE(derivedDicomUid(7, "dicom-instance", 0), derivedDicomUid(7, "dicom-instance", 1));
}

TEST(CtDicom, PydicomReadsTheSameGeometryAndValues) {
  if (!fs::exists("/usr/bin/python3"))
    GTEST_SKIP() << "/usr/bin/python3 is absent";
  if (std::system("/usr/bin/python3 -c 'import pydicom' >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "pydicom is not installed for /usr/bin/python3";
  }
  const core::CtImage v = dicomTestVolume();
  const test::TempDir dir;
  const std::string folder = dir.file("series");
  writeDicomSeries(folder, v, DicomSeriesInfo{});
  const std::vector<std::array<int, 3>> voxels = {{0, 0, 0},  {39, 29, 5}, {39, 0, 1}, {20, 15, 2},
                                                  {7, 22, 4}, {30, 3, 3},  {19, 14, 0}};
  std::string command =
      "/usr/bin/python3 " ECHOREG_SIMULATION_TEST_DIR "/read_dicom_series.py '" + folder + "'";
  for (const auto& p : voxels) {
    command += " " + std::to_string(p[0]) + "," + std::to_string(p[1]) + "," + std::to_string(p[2]);
  }
  const std::string output = dir.file("out.json");
  ASSERT_EQ(std::system((command + " > '" + output + "'").c_str()), 0) << command;
  const nlohmann::json json = nlohmann::json::parse(readBytes(output));
  const auto& slices = json.at("slices");
  ASSERT_EQ(slices.size(), static_cast<std::size_t>(v.dimensions[2]));
  for (int k = 0; k < v.dimensions[2]; ++k) {
    SCOPED_TRACE(k);
    const auto& s = slices.at(static_cast<std::size_t>(k));
    const Eigen::Vector3d first = v.voxelCentreMm(0, 0, k);
    EXPECT_EQ(s.at("transferSyntax"), "1.2.840.10008.1.2.1");
    EXPECT_EQ(s.at("sopClass"), "1.2.840.10008.5.1.4.1.1.2");
    EXPECT_EQ(s.at("sopInstance"), s.at("mediaStorageSopInstance"));
    EXPECT_EQ(s.at("rows").get<int>(), 30);
    EXPECT_EQ(s.at("columns").get<int>(), 40);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(s.at("position").at(static_cast<std::size_t>(a)).get<double>(), first[a], 1e-9);
    }
    EXPECT_EQ(s.at("orientation").get<std::vector<double>>(),
              (std::vector<double>{1, 0, 0, 0, 1, 0}));
    EXPECT_EQ(s.at("pixelSpacing").get<std::vector<double>>(), (std::vector<double>{0.7, 0.7}));
    EXPECT_EQ(s.at("thickness").get<double>(), v.sliceThicknessMm[static_cast<std::size_t>(k)]);
    EXPECT_NEAR(s.at("location").get<double>(), v.sliceLocationsMm[static_cast<std::size_t>(k)],
                1e-9);
    EXPECT_EQ(s.at("intercept").get<double>(), -1024.0);
    EXPECT_EQ(s.at("slope").get<double>(), 1.0);
    EXPECT_EQ(s.at("rescaleType"), "HU");
    EXPECT_EQ(s.at("bitsStored").get<int>(), 12);
    EXPECT_EQ(s.at("pixelRepresentation").get<int>(), 0);
    EXPECT_EQ(s.at("photometric"), "MONOCHROME2");
    EXPECT_EQ(s.at("kvp").get<double>(), 120.0);
  }
  const auto& values = json.at("voxels");
  ASSERT_EQ(values.size(), voxels.size());
  for (std::size_t n = 0; n < voxels.size(); ++n) {
    const auto& p = voxels[n];
    EXPECT_EQ(values.at(n).at("hu").get<double>(), v.at(p[0], p[1], p[2]))
        << p[0] << "," << p[1] << "," << p[2];
  }
}

bool hasTemporarySibling(const std::string& folder) {
  for (const auto& entry : fs::directory_iterator(fs::path(folder).parent_path())) {
    if (entry.path().filename().string().find(".tmp-") != std::string::npos)
      return true;
  }
  return false;
}

TEST(CtDicom, RefusesANonEmptyOrUnwritableFolderAndLeavesNothing) {
  const core::CtImage v = dicomTestVolume();
  const test::TempDir dir;

  // Existing, non-empty: refused, contents untouched.
  const std::string full = dir.file("full");
  fs::create_directory(full);
  std::ofstream(full + "/keep.txt") << "keep";
  try {
    writeDicomSeries(full, v, DicomSeriesInfo{});
    ADD_FAILURE() << "no exception";
  } catch (const core::FileError& e) {
    EXPECT_EQ(e.path(), full);
  }
  EXPECT_EQ(readBytes(full + "/keep.txt"), "keep");
  EXPECT_FALSE(hasTemporarySibling(full));

  // The parent is a file: nothing can be created there.
  std::ofstream(dir.file("plain")) << "x";
  EXPECT_THROW(writeDicomSeries(dir.file("plain") + "/ct", v, DicomSeriesInfo{}), core::FileError);

  // The folder is a file.
  EXPECT_THROW(writeDicomSeries(dir.file("plain"), v, DicomSeriesInfo{}), core::FileError);

  // A read-only parent (only meaningful when not running as root).
  if (::geteuid() != 0) {
    const std::string locked = dir.file("locked");
    fs::create_directory(locked);
    fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
    EXPECT_THROW(writeDicomSeries(locked + "/ct", v, DicomSeriesInfo{}), core::FileError);
    EXPECT_TRUE(fs::is_empty(locked));
    fs::permissions(locked, fs::perms::owner_all);
  }
  EXPECT_FALSE(hasTemporarySibling(full));

  // An existing empty folder is fine.
  const std::string empty = dir.file("empty");
  fs::create_directory(empty);
  writeDicomSeries(empty + "/", v, DicomSeriesInfo{});
  EXPECT_EQ(std::distance(fs::directory_iterator(empty), fs::directory_iterator()),
            v.dimensions[2]);
  EXPECT_FALSE(hasTemporarySibling(empty));

  // An inconsistent volume is refused before anything is written.
  core::CtImage bad = v;
  bad.hu[3] = 4000;
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), bad, DicomSeriesInfo{}), std::invalid_argument);
  bad = v;
  bad.hu.pop_back();
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), bad, DicomSeriesInfo{}), std::invalid_argument);
  bad = v;
  bad.direction << 0, 1, 0, 1, 0, 0, 0, 0, 1;  // not axial as written
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), bad, DicomSeriesInfo{}), std::invalid_argument);
  bad = v;
  bad.sliceThicknessMm.clear();  // the writer needs each slice's thickness
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), bad, DicomSeriesInfo{}), std::invalid_argument);
  bad = v;
  bad.groups.back().count -= 1;  // groups not covering every slice
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), bad, DicomSeriesInfo{}), std::invalid_argument);
  bad = v;
  bad.sliceLocationsMm[1] = bad.sliceLocationsMm[0];  // not increasing
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), bad, DicomSeriesInfo{}), std::invalid_argument);
  DicomSeriesInfo badInfo;
  badInfo.studyDate = "2008-12-01";
  EXPECT_THROW(writeDicomSeries(dir.file("bad"), v, badInfo), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir.file("bad")));
}

}  // namespace
}  // namespace echoreg::simulation
