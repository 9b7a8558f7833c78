// The DICOM module (libechoreg_dicom, dicom/) opened beside the executable: found where the build
// tree and an installation put it; a missing, foreign or other build's module is a FileError
// naming its path, not a crash; an exception thrown inside it reaches the caller as its own type.
#include "dicom_module_call.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/loadable_module.hpp"
#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/simulation/ct.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

namespace dicom = echoreg::dicom;
using echoreg::core::CtImage;
using echoreg::segmentation::DicomReadOptions;
using echoreg::segmentation::DicomSeriesRead;

CtImage smallVolume() {
  CtImage volume =
      echoreg::core::axialCtImage(6, 5, 0.5, {-1.25, 2.5}, {{"knee", {0.0, 1.0, 2.0}, 1.0}});
  volume.hu.resize(static_cast<std::size_t>(6 * 5 * 3));
  for (std::size_t v = 0; v < volume.hu.size(); ++v)
    volume.hu[v] = static_cast<std::int16_t>(static_cast<int>(v) * 29 - 400);
  return volume;
}

void writeSmallSeries(const std::string& folder) {
  echoreg::simulation::DicomSeriesInfo info;
  info.uidSeed = 5;
  echoreg::simulation::writeDicomSeries(folder, smallVolume(), info);
}

// Runs `work`, which must throw FileError; returns its message.
template <typename Work>
std::string fileErrorOf(Work work) {
  try {
    work();
  } catch (const echoreg::core::FileError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no FileError";
  return {};
}

DicomSeriesRead readWith(const std::filesystem::path& modulePath, const std::string& folder,
                         const DicomReadOptions& options = {}) {
  const auto read =
      dicom::dicomFunction<dicom::ReadSeriesFunction>(dicom::kReadSeriesSymbol, modulePath);
  DicomSeriesRead result;
  std::exception_ptr error;
  read(&folder, &options, 1, &result, &error);
  dicom::rethrowFromModule(error);
  return result;
}

TEST(DicomModule, LiesInLibEchoregBesideTheExecutablesFolder) {
  const std::filesystem::path path = dicom::dicomModulePath();
  EXPECT_EQ(path.filename(), "libechoreg_dicom.so");
  EXPECT_EQ(path.parent_path().filename(), "echoreg");
  EXPECT_EQ(path.parent_path().parent_path().filename(), "lib");
  ASSERT_TRUE(std::filesystem::exists(path)) << path;
  echoreg::test::TempDir dir;
  const std::string folder = dir.file("series");
  writeSmallSeries(folder);
  const DicomSeriesRead read = readWith(path, folder);
  EXPECT_EQ(read.image.dimensions, (std::array<int, 3>{6, 5, 3}));
  EXPECT_EQ(read.image.hu, smallVolume().hu);
  EXPECT_EQ(read.files, (std::vector<std::string>{"IM000001.dcm", "IM000002.dcm", "IM000003.dcm"}));
}

TEST(DicomModule, AMissingModuleIsAFileErrorNamingIt) {
  echoreg::test::TempDir dir;
  const std::string missing = dir.file("lib/echoreg/libechoreg_dicom.so");
  const std::string message = fileErrorOf([&] { readWith(missing, dir.path()); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;
  EXPECT_NE(message.find("cannot open the DICOM module"), std::string::npos) << message;
  EXPECT_NE(message.find("echoreg_dicom"), std::string::npos) << message;
}

TEST(DicomModule, AFileThatIsNotTheModuleIsRefused) {
  echoreg::test::TempDir dir;
  const std::string text = dir.file("libechoreg_dicom.so");
  std::ofstream(text) << "not a shared object\n";
  const std::string message = fileErrorOf([&] { readWith(text, dir.path()); });
  EXPECT_NE(message.find(text), std::string::npos) << message;
  // A shared object that is some other library: opens, but has no entry points.
  const std::string other = "/lib/x86_64-linux-gnu/libz.so.1";
  if (std::filesystem::exists(other)) {
    const std::string foreign = fileErrorOf([&] { readWith(other, dir.path()); });
    EXPECT_NE(foreign.find("is not echoreg's DICOM module (no echoreg_dicom_abi)"),
              std::string::npos)
        << foreign;
  }
  // The renderer module is echoreg's, but not this one.
  const std::filesystem::path renderer =
      dicom::dicomModulePath().parent_path() / "libechoreg_render_gl.so";
  if (std::filesystem::exists(renderer)) {
    const std::string wrong = fileErrorOf([&] { readWith(renderer, dir.path()); });
    EXPECT_NE(wrong.find(renderer.string()), std::string::npos) << wrong;
    EXPECT_NE(wrong.find("is not echoreg's DICOM module"), std::string::npos) << wrong;
  }
}

TEST(DicomModule, AModuleOfAnotherBuildIsRefused) {
  // The real module, asked for by an executable whose types or version differ.
  const echoreg::core::ModuleIdentity other{"DICOM module", "echoreg_dicom",
                                            "reads and writes DICOM", dicom::kAbiSymbol,
                                            "echoreg 0.0.0 / another compiler"};
  const std::filesystem::path path = dicom::dicomModulePath();
  const std::string message =
      fileErrorOf([&] { echoreg::core::moduleSymbol(path, other, dicom::kListSeriesSymbol); });
  EXPECT_NE(message.find(path.string()), std::string::npos) << message;
  EXPECT_NE(message.find("is the DICOM module of another build"), std::string::npos) << message;
  EXPECT_NE(message.find(dicom::dicomAbi()), std::string::npos) << message;
  // The right identity still opens it afterwards.
  EXPECT_NO_THROW(dicom::dicomFunction<dicom::ListSeriesFunction>(dicom::kListSeriesSymbol));
}

struct StopReading {
  int slicesDone;
};

TEST(DicomModule, ExceptionsThrownInsideReachTheCallerAsTheirOwnType) {
  echoreg::test::TempDir dir;
  const std::string missing = dir.file("no-such-series");
  const std::string message = fileErrorOf([&] { echoreg::segmentation::readDicomSeries(missing); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;

  CtImage empty = smallVolume();
  empty.dimensions[0] = 0;
  EXPECT_THROW(echoreg::simulation::writeDicomSeries(dir.file("bad"), empty, {}),
               std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad")));

  // The caller's own exception, thrown by its progress callback on a worker thread of the module.
  const std::string folder = dir.file("series");
  writeSmallSeries(folder);
  DicomReadOptions options;
  options.threads = 2;
  options.progress = [](int done, int) {
    if (done == 2)
      throw StopReading{done};
  };
  try {
    echoreg::segmentation::readDicomSeries(folder, options);
    ADD_FAILURE() << "the progress callback's exception did not stop the read";
  } catch (const StopReading& stop) {
    EXPECT_EQ(stop.slicesDone, 2);
  }
}

}  // namespace
