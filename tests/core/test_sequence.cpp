// PLUS sequence files: round trips of every element type through every layout, conversions
// between the formats, hand-written headers, and the real PLUS files of ../shared/data.
#include "echoreg/core/sequence.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

namespace fs = std::filesystem;

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof(double)) == 0;
}

bool sameBits(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 16) == 0;
}

bool sameBits(const std::optional<double>& a, const std::optional<double>& b) {
  return a.has_value() == b.has_value() && (!a || sameBits(*a, *b));
}

// Every part of two sequences equal, numbers bit for bit.
void expectSameSequence(const Sequence& expected, const Sequence& actual) {
  EXPECT_EQ(expected.elementType, actual.elementType);
  EXPECT_EQ(expected.frameSize, actual.frameSize);
  EXPECT_TRUE(expected.pixels == actual.pixels) << "pixels differ";
  EXPECT_TRUE(
      sameBits(expected.acquisition.samplingFrequencyHz, actual.acquisition.samplingFrequencyHz));
  EXPECT_TRUE(sameBits(expected.acquisition.delayS, actual.acquisition.delayS));
  EXPECT_TRUE(sameBits(expected.acquisition.speedOfSoundMps, actual.acquisition.speedOfSoundMps));
  EXPECT_EQ(expected.acquisition.transducer, actual.acquisition.transducer);
  EXPECT_EQ(expected.extraHeader, actual.extraHeader);
  ASSERT_EQ(expected.frames.size(), actual.frames.size());
  for (std::size_t i = 0; i < expected.frames.size(); ++i) {
    const SequenceFrame& want = expected.frames[i];
    const SequenceFrame& got = actual.frames[i];
    EXPECT_TRUE(sameBits(want.timestampS, got.timestampS)) << "timestamp of frame " << i;
    EXPECT_EQ(want.fields, got.fields) << "fields of frame " << i;
    ASSERT_EQ(want.transforms.size(), got.transforms.size()) << "frame " << i;
    for (const auto& [name, transform] : want.transforms) {
      const auto found = got.transforms.find(name);
      ASSERT_NE(found, got.transforms.end()) << name << " of frame " << i;
      EXPECT_TRUE(sameBits(transform.matrix, found->second.matrix)) << name << " of frame " << i;
      EXPECT_EQ(transform.status, found->second.status) << name << " of frame " << i;
    }
  }
}

Eigen::Matrix4d randomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> uniform(-400.0, 400.0);
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  for (int row = 0; row < 3; ++row) {
    for (int column = 0; column < 4; ++column)
      matrix(row, column) = uniform(rng) / 3.0;
  }
  matrix(3, 0) = -0.0;  // PLUS writes "-0"; the sign must survive
  return matrix;
}

// A sequence with every kind of metadata: transforms with statuses, missing timestamps, fields
// whose values hold the separators of both formats, acquisition settings, extra header keys.
Sequence makeSequence(ElementType type, int samples, std::size_t frameCount, bool nrrdFields) {
  std::mt19937 rng(20240611);
  Sequence sequence;
  sequence.elementType = samples > 0 ? type : ElementType::None;
  sequence.frameSize = {samples, samples > 0 ? 1 : 0};
  sequence.frames.resize(frameCount);
  for (std::size_t i = 0; i < frameCount; ++i) {
    SequenceFrame& frame = sequence.frames[i];
    if (i != 3)
      frame.timestampS = 1.0 / 3.0 + 0.0123456789 * static_cast<double>(i);
    if (i != 2) {
      frame.transforms["ProbeToTracker"] = {randomPose(rng), i % 3 == 0 ? "INVALID" : "OK"};
      frame.transforms["FemurToTracker"] = {randomPose(rng), "OK"};
    }
    frame.fields = {{"ImageStatus", i % 2 == 0 ? "OK" : "INVALID"}, {"Note", "a = b: c:=d"}};
  }
  sequence.pixels.resize(sequence.frames.size() * sequence.samplesPerFrame() *
                         elementSize(sequence.elementType));
  std::uniform_int_distribution<int> byte(0, 255);
  for (std::uint8_t& value : sequence.pixels)
    value = static_cast<std::uint8_t>(byte(rng));
  sequence.acquisition.samplingFrequencyHz = 50e6;
  sequence.acquisition.delayS = 2.0e-6 / 3.0;
  sequence.acquisition.speedOfSoundMps = 1540.0;
  sequence.acquisition.transducer = "Olympus V310 (5 MHz)";
  sequence.extraHeader = {{"UltrasoundImageOrientation", "MFA"},
                          {"Kinds", "domain domain list"},
                          {"ultrasound image type", "RF"}};
  if (nrrdFields) {
    sequence.extraHeader.emplace_back("nrrd-field:space dimension", "2");
    sequence.extraHeader.emplace_back("nrrd-field:space directions", "(1,0) (0,1) none");
  }
  return sequence;
}

struct Layout {
  const char* name;
  const char* fileName;
  bool compress;
};

const Layout kLayouts[] = {
    {"MhaRaw", "capture.mha", false},   {"MhaZlib", "capture.mha", true},
    {"MhdRaw", "capture.mhd", false},   {"MhdZraw", "capture.mhd", true},
    {"NrrdRaw", "capture.nrrd", false}, {"NrrdGzip", "capture.nrrd", true},
};

const ElementType kElementTypes[] = {ElementType::UInt8, ElementType::Int8, ElementType::Int16,
                                     ElementType::Float32, ElementType::None};

bool isNrrd(const Layout& layout) {
  return std::string(layout.fileName).find(".nrrd") != std::string::npos;
}
bool isMhd(const Layout& layout) {
  return std::string(layout.fileName).find(".mhd") != std::string::npos;
}

// The files a layout writes: the header, plus the data file of an .mhd with pixels.
std::vector<std::string> writtenFiles(const std::string& folder, const Layout& layout,
                                      const Sequence& sequence) {
  std::vector<std::string> files{folder + "/" + layout.fileName};
  if (isMhd(layout) && sequence.hasPixels()) {
    files.push_back(folder + "/capture" + (layout.compress ? ".zraw" : ".raw"));
  }
  return files;
}

class SequenceRoundTrip : public ::testing::TestWithParam<std::tuple<ElementType, Layout>> {};

TEST_P(SequenceRoundTrip, ReadsBackIdenticallyAndRewritesTheSameBytes) {
  const auto [type, layout] = GetParam();
  const Sequence original =
      makeSequence(type, type == ElementType::None ? 0 : 37, 7, isNrrd(layout));
  test::TempDir dir;
  fs::create_directories(dir.file("first"));
  fs::create_directories(dir.file("second"));
  const std::string first = dir.file("first") + "/" + layout.fileName;
  const std::string second = dir.file("second") + "/" + layout.fileName;

  writeSequence(original, first, {std::nullopt, layout.compress});
  const Sequence readBack = readSequence(first);
  expectSameSequence(original, readBack);

  writeSequence(readBack, second, {std::nullopt, layout.compress});
  const std::vector<std::string> firstFiles = writtenFiles(dir.file("first"), layout, original);
  const std::vector<std::string> secondFiles = writtenFiles(dir.file("second"), layout, original);
  for (std::size_t i = 0; i < firstFiles.size(); ++i) {
    ASSERT_TRUE(fs::exists(firstFiles[i])) << firstFiles[i];
    EXPECT_EQ(readText(firstFiles[i]), readText(secondFiles[i])) << firstFiles[i];
  }
  // Exactly the expected files, no temporary left behind.
  EXPECT_EQ(static_cast<std::size_t>(
                std::distance(fs::directory_iterator(dir.file("first")), fs::directory_iterator())),
            firstFiles.size());
}

TEST_P(SequenceRoundTrip, WritesTheLayoutItNames) {
  const auto [type, layout] = GetParam();
  const Sequence sequence = makeSequence(type, type == ElementType::None ? 0 : 37, 3, false);
  test::TempDir dir;
  const std::string path = dir.file(layout.fileName);
  writeSequence(sequence, path, {std::nullopt, layout.compress});
  const std::string text = readText(path);
  const bool compressedPixels = layout.compress && sequence.hasPixels();
  if (isNrrd(layout)) {
    EXPECT_EQ(text.rfind("NRRD0004\n", 0), 0u);
    EXPECT_NE(text.find(compressedPixels ? "encoding: gzip\n" : "encoding: raw\n"),
              std::string::npos);
    EXPECT_NE(text.find("EchoregSamplingFrequencyHz:=50000000\n"), std::string::npos);
    EXPECT_NE(text.find("Seq_Frame0001_ProbeToTrackerTransformStatus:=OK\n"), std::string::npos);
    if (compressedPixels) {
      const std::size_t data = text.find("\n\n") + 2;
      EXPECT_EQ(text.substr(data, 2), "\x1f\x8b");  // gzip magic
    }
  } else {
    EXPECT_EQ(text.rfind("ObjectType = Image\nNDims = 3\n", 0), 0u);
    EXPECT_NE(text.find(compressedPixels ? "CompressedData = True\nCompressedDataSize = "
                                         : "CompressedData = False\n"),
              std::string::npos);
    EXPECT_NE(text.find("EchoregSamplingFrequencyHz = 50000000\n"), std::string::npos);
    const std::string dataFile = isMhd(layout) && sequence.hasPixels()
                                     ? std::string(layout.compress ? "capture.zraw" : "capture.raw")
                                     : std::string("LOCAL");
    EXPECT_NE(text.find("\nElementDataFile = " + dataFile + "\n"), std::string::npos);
    if (type == ElementType::None) {
      EXPECT_NE(text.find("DimSize = 0 0 3\n"), std::string::npos);
      EXPECT_NE(text.find("ElementType = MET_OTHER\n"), std::string::npos);
    }
  }
}

std::string layoutTestName(const ::testing::TestParamInfo<std::tuple<ElementType, Layout>>& info) {
  return std::string(elementTypeName(std::get<0>(info.param))) + "_" + std::get<1>(info.param).name;
}

INSTANTIATE_TEST_SUITE_P(AllTypesAndLayouts, SequenceRoundTrip,
                         ::testing::Combine(::testing::ValuesIn(kElementTypes),
                                            ::testing::ValuesIn(kLayouts)),
                         layoutTestName);

TEST(SequenceFormats, MetaImageExtrasBecomeNrrdKeyValuesAndBack) {
  test::TempDir dir;
  const Sequence original = makeSequence(ElementType::Int16, 16, 4, false);
  writeSequence(original, dir.file("a.mha"));
  writeSequence(readSequence(dir.file("a.mha")), dir.file("b.nrrd"));
  const std::string nrrd = readText(dir.file("b.nrrd"));
  EXPECT_NE(nrrd.find("\nUltrasoundImageOrientation:=MFA\n"), std::string::npos);
  EXPECT_NE(nrrd.find("\nKinds:=domain domain list\n"), std::string::npos);
  writeSequence(readSequence(dir.file("b.nrrd")), dir.file("c.mha"));
  expectSameSequence(original, readSequence(dir.file("c.mha")));
}

TEST(SequenceFormats, NrrdFieldsRoundTripInNrrdAndAreDroppedInMetaImage) {
  test::TempDir dir;
  const Sequence original = makeSequence(ElementType::UInt8, 8, 2, true);
  writeSequence(original, dir.file("a.nrrd"));
  const std::string nrrd = readText(dir.file("a.nrrd"));
  EXPECT_NE(nrrd.find("\nspace directions: (1,0) (0,1) none\n"), std::string::npos);
  EXPECT_NE(nrrd.find("\nultrasound image type:=RF\n"), std::string::npos);

  writeSequence(readSequence(dir.file("a.nrrd")), dir.file("b.mha"));
  const std::string mha = readText(dir.file("b.mha"));
  EXPECT_EQ(mha.find("space directions"), std::string::npos);
  EXPECT_NE(mha.find("\nultrasound image type = RF\n"), std::string::npos);
  const Sequence fromMha = readSequence(dir.file("b.mha"));
  Sequence expected = original;
  expected.extraHeader.resize(3);  // without the two nrrd-field entries
  expectSameSequence(expected, fromMha);
}

TEST(SequenceFormats, FormatOptionOverridesTheExtensionAndReadingGoesByContent) {
  test::TempDir dir;
  const Sequence original = makeSequence(ElementType::Float32, 5, 2, false);
  writeSequence(original, dir.file("looks-like.mha"), {SequenceFormat::Nrrd, true});
  EXPECT_EQ(readText(dir.file("looks-like.mha")).rfind("NRRD", 0), 0u);
  expectSameSequence(original, readSequence(dir.file("looks-like.mha")));
}

TEST(SequenceFormats, ManyFramesUseLongerFrameNumbers) {
  test::TempDir dir;
  Sequence sequence;
  sequence.frames.resize(10001);
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    sequence.frames[i].timestampS = 0.01 * static_cast<double>(i);
  }
  writeSequence(sequence, dir.file("long.mha"));
  EXPECT_NE(readText(dir.file("long.mha")).find("\nSeq_Frame10000_Timestamp = 100\n"),
            std::string::npos);
  expectSameSequence(sequence, readSequence(dir.file("long.mha")));
}

// A small hand-written MetaImage header of int16 A-lines, as other writers lay it out.
std::string handWrittenHeader(const std::string& frameKeys, const std::string& extraKeys = "") {
  return "ObjectType = Image\nNDims = 3\nAnatomicalOrientation = RAI\nBinaryData = True\n" +
         extraKeys + "CompressedData = False\nDimSize = 2 1 3              \n" +
         "ElementNumberOfChannels = 1\nElementType = MET_SHORT\n" + frameKeys;
}

std::string int16Bytes(const std::vector<std::int16_t>& values, bool bigEndian) {
  std::string bytes;
  for (const std::int16_t value : values) {
    const auto bits = static_cast<std::uint16_t>(value);
    const char low = static_cast<char>(bits & 0xff);
    const char high = static_cast<char>(bits >> 8);
    bytes += bigEndian ? high : low;
    bytes += bigEndian ? low : high;
  }
  return bytes;
}

TEST(SequenceHandWritten, MetaImageKeysInAnyFormTheyAppearIn) {
  test::TempDir dir;
  const std::string frameKeys =
      "Seq_Frame0000_ProbeToTrackerTransformStatus = MISSING\n"  // a status without a matrix
      "Seq_Frame00001_ProbeToTrackerTransform = 1 0 0 10 0 1 0 20 0 0 1 30 -0 0 -0 1 \n"
      "Seq_Frame0002_Timestamp = 12.5\r\n"
      "Seq_Frame0002_Status = OK\n"
      "Seq_Frame0002_ImageStatus = INVALID\n";
  writeText(dir.file("hand.mha"), handWrittenHeader(frameKeys) + "ElementDataFile = LOCAL\n" +
                                      int16Bytes({1, -2, 300, -400, 32767, -32768}, false));
  const Sequence sequence = readSequence(dir.file("hand.mha"));
  EXPECT_EQ(sequence.elementType, ElementType::Int16);
  EXPECT_EQ(sequence.frameSize, (std::array<int, 2>{2, 1}));
  ASSERT_EQ(sequence.frameCount(), 3u);
  const TrackedTransform& statusOnly = sequence.frames[0].transforms.at("ProbeToTracker");
  EXPECT_EQ(statusOnly.status, "MISSING");
  EXPECT_FALSE(statusOnly.valid());
  EXPECT_TRUE(statusOnly.matrix.isIdentity());
  const TrackedTransform& matrixOnly = sequence.frames[1].transforms.at("ProbeToTracker");
  EXPECT_EQ(matrixOnly.status, "OK");
  EXPECT_EQ(matrixOnly.matrix(1, 3), 20.0);
  EXPECT_TRUE(std::signbit(matrixOnly.matrix(3, 0)));
  EXPECT_EQ(sequence.frames[2].timestampS, 12.5);
  const std::vector<std::pair<std::string, std::string>> fields{{"Status", "OK"},
                                                                {"ImageStatus", "INVALID"}};
  EXPECT_EQ(sequence.frames[2].fields, fields);
  EXPECT_EQ(sequence.extraHeader,
            (std::vector<std::pair<std::string, std::string>>{{"AnatomicalOrientation", "RAI"}}));
  std::vector<float> samples;
  sequence.frameSamples(2, samples);
  EXPECT_EQ(samples, (std::vector<float>{32767.0f, -32768.0f}));
}

TEST(SequenceHandWritten, BigEndianMetaImageIsSwapped) {
  test::TempDir dir;
  writeText(dir.file("msb.mha"), handWrittenHeader("", "BinaryDataByteOrderMSB = True\n") +
                                     "ElementDataFile = LOCAL\n" +
                                     int16Bytes({1, -2, 300, -400, 32767, -32768}, true));
  const Sequence sequence = readSequence(dir.file("msb.mha"));
  std::vector<float> samples;
  sequence.frameSamples(1, samples);
  EXPECT_EQ(samples, (std::vector<float>{300.0f, -400.0f}));
}

TEST(SequenceHandWritten, BigEndianNrrdWithDetachedDataFile) {
  test::TempDir dir;
  writeText(dir.file("data.bin"), int16Bytes({5, 6, 7, 8, -9, 10}, true));
  writeText(dir.file("detached.nhdr"),
            "NRRD0005\n# a comment\ndimension: 3\ntype: short\nsizes: 2 1 3\nendian: big\n"
            "encoding: raw\ndata file: data.bin\nSeq_Frame0002_Timestamp:=0.5\n");
  const Sequence sequence = readSequence(dir.file("detached.nhdr"));
  EXPECT_EQ(sequence.elementType, ElementType::Int16);
  std::vector<float> samples;
  sequence.frameSamples(2, samples);
  EXPECT_EQ(samples, (std::vector<float>{-9.0f, 10.0f}));
  EXPECT_EQ(sequence.frames[2].timestampS, 0.5);
  EXPECT_TRUE(sequence.extraHeader.empty());
}

TEST(SequenceMembers, FrameSamplesConvertsEveryElementType) {
  Sequence sequence;
  sequence.frameSize = {3, 1};
  sequence.frames.resize(2);
  std::vector<float> samples;

  sequence.elementType = ElementType::UInt8;
  sequence.pixels = {0, 1, 2, 200, 254, 255};
  sequence.frameSamples(1, samples);
  EXPECT_EQ(samples, (std::vector<float>{200.0f, 254.0f, 255.0f}));

  sequence.elementType = ElementType::Int8;
  sequence.frameSamples(1, samples);
  EXPECT_EQ(samples, (std::vector<float>{-56.0f, -2.0f, -1.0f}));

  sequence.elementType = ElementType::Int16;
  const std::vector<std::int16_t> shorts{1, -1, 1000, -1000, 32767, -32768};
  sequence.pixels.resize(shorts.size() * 2);
  std::memcpy(sequence.pixels.data(), shorts.data(), sequence.pixels.size());
  sequence.frameSamples(1, samples);
  EXPECT_EQ(samples, (std::vector<float>{-1000.0f, 32767.0f, -32768.0f}));

  sequence.elementType = ElementType::Float32;
  const std::vector<float> floats{0.5f, -1.25f, 3.0f, 1e-3f, -7.5f, 1e6f};
  sequence.pixels.resize(floats.size() * 4);
  std::memcpy(sequence.pixels.data(), floats.data(), sequence.pixels.size());
  sequence.frameSamples(0, samples);
  EXPECT_EQ(samples, (std::vector<float>{0.5f, -1.25f, 3.0f}));

  EXPECT_THROW(sequence.frameSamples(2, samples), std::out_of_range);
}

TEST(SequenceMembers, TransformNamesAreTheSortedUnion) {
  Sequence sequence;
  sequence.frames.resize(3);
  sequence.frames[0].transforms["StylusToTracker"] = {};
  sequence.frames[1].transforms["ReferenceToTracker"] = {};
  sequence.frames[1].transforms["StylusToTracker"] = {};
  sequence.frames[2].transforms["BeamToProbe"] = {};
  EXPECT_EQ(sequence.transformNames(),
            (std::vector<std::string>{"BeamToProbe", "ReferenceToTracker", "StylusToTracker"}));
  EXPECT_EQ(elementTypeName(ElementType::Int16), "int16");
  EXPECT_EQ(elementSize(ElementType::Float32), 4u);
  EXPECT_EQ(elementSize(ElementType::None), 0u);
}

// The pixels of a PLUS gzip NRRD decoded here with zlib alone, independently of the reader.
std::vector<std::uint8_t> inflateNrrdData(const std::string& path) {
  const std::string file = readText(path);
  const std::size_t data = file.find("\n\n") + 2;
  z_stream zs{};
  EXPECT_EQ(inflateInit2(&zs, 15 + 16), Z_OK);
  std::vector<std::uint8_t> out(11350u * 150u * 2u);
  std::vector<std::uint8_t> in(file.begin() + static_cast<std::ptrdiff_t>(data), file.end());
  zs.next_in = in.data();
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(inflate(&zs, Z_FINISH), Z_STREAM_END);
  EXPECT_EQ(zs.total_out, out.size());
  inflateEnd(&zs);
  return out;
}

TEST(SequenceRealFiles, AgilentScopeRecordingNrrd) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  const Sequence sequence = readSequence(path);
  EXPECT_EQ(sequence.elementType, ElementType::Int16);
  EXPECT_EQ(sequence.frameSize, (std::array<int, 2>{11350, 1}));
  ASSERT_EQ(sequence.frameCount(), 150u);
  const TrackedTransform& zOffset = sequence.frames[0].transforms.at("ZOffsetToTracker");
  EXPECT_EQ(zOffset.matrix(2, 3), 5.645142857142858);
  EXPECT_EQ(zOffset.status, "OK");
  ASSERT_TRUE(sequence.frames[0].timestampS.has_value());
  EXPECT_NEAR(*sequence.frames[0].timestampS, 3.114, 1e-12);
  EXPECT_EQ(*sequence.frames[0].timestampS, 3.114000000000033);  // the file's exact text
  EXPECT_EQ(sequence.frames[149].fields,
            (std::vector<std::pair<std::string, std::string>>{{"Status", "OK"}}));
  EXPECT_EQ(sequence.transformNames(), std::vector<std::string>{"ZOffsetToTracker"});
  const std::vector<std::pair<std::string, std::string>> extra{
      {"nrrd-field:kinds", "domain domain                list"},
      {"nrrd-field:space dimension", "2"},
      {"nrrd-field:space directions", "(1,0) (0,1) none"},
      {"nrrd-field:space origin", "(0,0)"},
      {"ultrasound image orientation", "MFA"},
      {"ultrasound image type", "BRIGHTNESS"}};
  EXPECT_EQ(sequence.extraHeader, extra);

  EXPECT_TRUE(sequence.pixels == inflateNrrdData(path));
  // Values measured with Python's zlib and array modules on the same file.
  std::vector<float> samples;
  sequence.frameSamples(0, samples);
  EXPECT_EQ((std::vector<float>(samples.begin(), samples.begin() + 4)),
            (std::vector<float>{1296.0f, 1312.0f, 1280.0f, 1232.0f}));
  std::int64_t sum = 0;
  for (std::size_t frame = 0; frame < sequence.frameCount(); ++frame) {
    sequence.frameSamples(frame, samples);
    for (const float sample : samples)
      sum += static_cast<std::int64_t>(sample);
  }
  EXPECT_EQ(sum, -504947936);
}

TEST(SequenceRealFiles, EightLandmarkPointsMetaImage) {
  ECHOREG_REQUIRE_SHARED_FILE(path,
                              "plus/EightLandmarkPointsTrackedForPhantomRegistration.igs.mha");
  const Sequence sequence = readSequence(path);
  EXPECT_EQ(sequence.elementType, ElementType::None);
  EXPECT_FALSE(sequence.hasPixels());
  EXPECT_TRUE(sequence.pixels.empty());
  ASSERT_EQ(sequence.frameCount(), 1000u);
  EXPECT_EQ(sequence.transformNames(),
            (std::vector<std::string>{"ReferenceToTracker", "StylusToTracker"}));
  const TrackedTransform& stylus = sequence.frames[0].transforms.at("StylusToTracker");
  EXPECT_EQ(stylus.matrix(0, 3), 315.55283203125);
  EXPECT_EQ(stylus.status, "OK");
  EXPECT_EQ(sequence.frames[999].timestampS, 347.0668714287492);
  EXPECT_EQ(sequence.frames[999].fields,
            (std::vector<std::pair<std::string, std::string>>{{"ImageStatus", "INVALID"}}));
  ASSERT_FALSE(sequence.extraHeader.empty());
  EXPECT_EQ(sequence.extraHeader.front(),
            (std::pair<std::string, std::string>{"AnatomicalOrientation", "RAI"}));
  EXPECT_EQ(sequence.extraHeader.back(),
            (std::pair<std::string, std::string>{"UltrasoundImageType", "XX"}));
}

TEST(SequenceRealFiles, RealFilesRewriteToIdenticalSequences) {
  ECHOREG_REQUIRE_SHARED_FILE(nrrd, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  ECHOREG_REQUIRE_SHARED_FILE(mha, "plus/EightLandmarkPointsTrackedForPhantomRegistration.igs.mha");
  test::TempDir dir;
  for (const std::string& source : {nrrd, mha}) {
    const Sequence original = readSequence(source);
    const std::string copy = dir.file(fs::path(source).filename().string());
    writeSequence(original, copy);
    expectSameSequence(original, readSequence(copy));
  }
  // Across formats the MetaImage copy of the NRRD loses only its NRRD fields.
  const Sequence original = readSequence(nrrd);
  writeSequence(original, dir.file("agilent.mhd"));
  Sequence expected = original;
  expected.extraHeader.erase(expected.extraHeader.begin(), expected.extraHeader.begin() + 4);
  expectSameSequence(expected, readSequence(dir.file("agilent.mhd")));
}

}  // namespace
}  // namespace echoreg::core
