// The CT series writer (GDCM), inside the DICOM module (dicom/CMakeLists.txt): one CT Image
// Storage file per slice, written into a temporary sibling folder that is renamed onto the target
// at the end. simulation::writeDicomSeries calls it through the module.
#include "echoreg/core/ct_image.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/simulation/ct.hpp"

#include <fmt/format.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmImage.h>
#include <gdcmImageWriter.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmPixelFormat.h>
#include <gdcmTag.h>
#include <gdcmTransferSyntax.h>
#include <gdcmVR.h>

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace echoreg::simulation {

namespace {

namespace fs = std::filesystem;

constexpr const char* kCtImageStorage = "1.2.840.10008.5.1.4.1.1.2";
constexpr int kRescaleIntercept = kCtMinHu;  // stored = HU + 1024
constexpr int kBoneWindowCentre = 400;
constexpr int kBoneWindowWidth = 1800;

/// A DS (decimal string) value of at most 16 characters.
std::string decimalString(double value) {
  for (int precision = 12; precision >= 6; --precision) {
    std::string text = fmt::format("{:.{}g}", value, precision);
    if (text == "-0")
      text = "0";
    if (text.size() <= 16)
      return text;
  }
  throw std::invalid_argument(fmt::format("{} does not fit a DICOM decimal string", value));
}

/// Sets a string-valued element, padded to even length (UI with NUL, the others with a space).
void setString(gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element, gdcm::VR vr,
               std::string value) {
  if (value.size() % 2 != 0)
    value.push_back(vr == gdcm::VR::UI ? '\0' : ' ');
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<std::uint32_t>(value.size()));
  ds.Replace(de);
}

void requireText(const std::string& value, std::size_t maxLength, const std::string& what,
                 bool digitsOnly) {
  bool ok = value.size() <= maxLength;
  for (char c : value) {
    const auto u = static_cast<unsigned char>(c);
    if (digitsOnly ? !std::isdigit(u) : (u < 0x20 || u > 0x7e || c == '\\'))
      ok = false;
  }
  if (!ok) {
    throw std::invalid_argument(
        fmt::format("DicomSeriesInfo.{} = \"{}\": expected at most {} {}", what, value, maxLength,
                    digitsOnly ? "digits" : "printable ASCII characters without backslash"));
  }
}

/// The z of slice k: the location the slice was made at when kept (CtImage::sliceLocationsMm),
/// otherwise the origin's plus the slice's position.
double sliceZ(const core::CtImage& volume, std::size_t k) {
  return volume.sliceLocationsMm.empty() ? volume.originMm.z() + volume.slicePositionsMm[k]
                                         : volume.sliceLocationsMm[k];
}

void checkInputs(const core::CtImage& volume, const DicomSeriesInfo& info) {
  const int columns = volume.dimensions[0];
  const int rows = volume.dimensions[1];
  if (columns < 1 || columns > 65535 || rows < 1 || rows > 65535) {
    throw std::invalid_argument(
        fmt::format("CtImage is {} x {} pixels, expected 1..65535 each", columns, rows));
  }
  if (!std::isfinite(volume.pixelSpacingMm.x()) || volume.pixelSpacingMm.x() <= 0.0 ||
      volume.pixelSpacingMm.y() != volume.pixelSpacingMm.x()) {
    throw std::invalid_argument(
        fmt::format("CtImage.pixelSpacingMm = {} x {} is not positive and square",
                    volume.pixelSpacingMm.x(), volume.pixelSpacingMm.y()));
  }
  if (volume.direction != Eigen::Matrix3d::Identity()) {
    throw std::invalid_argument(
        "CtImage.direction is not the identity: the writer writes axial slices only");
  }
  if (!std::isfinite(volume.originMm.x()) || !std::isfinite(volume.originMm.y())) {
    throw std::invalid_argument(fmt::format("CtImage.originMm = {} {} {} is not finite",
                                            volume.originMm.x(), volume.originMm.y(),
                                            volume.originMm.z()));
  }
  if (volume.dimensions[2] < 1)
    throw std::invalid_argument("CtImage has no slices");
  const auto slices = static_cast<std::size_t>(volume.dimensions[2]);
  if (slices > 999999)
    throw std::invalid_argument("CtImage has more than 999999 slices");
  if (volume.slicePositionsMm.size() != slices || volume.sliceThicknessMm.size() != slices ||
      (!volume.sliceLocationsMm.empty() && volume.sliceLocationsMm.size() != slices)) {
    throw std::invalid_argument(
        fmt::format("CtImage has {} slices but {} slice positions, {} thicknesses and {} locations",
                    slices, volume.slicePositionsMm.size(), volume.sliceThicknessMm.size(),
                    volume.sliceLocationsMm.size()));
  }
  if (!volume.groupNames.empty() && volume.groupNames.size() != volume.groups.size()) {
    throw std::invalid_argument(fmt::format("CtImage has {} groups but {} group names",
                                            volume.groups.size(), volume.groupNames.size()));
  }
  std::size_t covered = 0;
  for (const core::CtSliceGroup& group : volume.groups) {
    if (group.count < 1 || static_cast<std::size_t>(group.firstSlice) != covered) {
      throw std::invalid_argument(fmt::format(
          "CtImage.groups: a group starts at slice {} with {} slices, expected slice {}",
          group.firstSlice, group.count, covered));
    }
    covered += static_cast<std::size_t>(group.count);
  }
  if (covered != slices) {
    throw std::invalid_argument(
        fmt::format("CtImage.groups cover {} slices of {}", covered, slices));
  }
  for (std::size_t k = 0; k < slices; ++k) {
    const double z = sliceZ(volume, k);
    if (!std::isfinite(z) || (k > 0 && z <= sliceZ(volume, k - 1))) {
      throw std::invalid_argument(
          fmt::format("CtImage: slice {} at z = {} is not finite and increasing", k, z));
    }
    if (!std::isfinite(volume.sliceThicknessMm[k]) || volume.sliceThicknessMm[k] <= 0.0) {
      throw std::invalid_argument(fmt::format("CtImage.sliceThicknessMm[{}] = {} is not positive",
                                              k, volume.sliceThicknessMm[k]));
    }
  }
  const std::size_t expected = volume.voxelCount();
  if (volume.hu.size() != expected) {
    throw std::invalid_argument(fmt::format("CtImage.hu has {} voxels, expected {} x {} x {} = {}",
                                            volume.hu.size(), columns, rows, slices, expected));
  }
  for (std::size_t v = 0; v < expected; ++v) {
    if (volume.hu[v] < kCtMinHu || volume.hu[v] > kCtMaxHu) {
      throw std::invalid_argument(
          fmt::format("CtImage.hu[{}] = {} is outside the stored range [{}, {}]", v, volume.hu[v],
                      kCtMinHu, kCtMaxHu));
    }
  }
  requireText(info.patientName, 64, "patientName", false);
  requireText(info.patientId, 64, "patientId", false);
  requireText(info.studyDescription, 64, "studyDescription", false);
  requireText(info.seriesDescription, 64, "seriesDescription", false);
  requireText(info.studyDate, 8, "studyDate", true);
  requireText(info.studyTime, 6, "studyTime", true);
  if (info.studyDate.size() != 8)
    requireText(info.studyDate, 0, "studyDate (YYYYMMDD)", true);
  if (info.studyTime.size() != 6)
    requireText(info.studyTime, 0, "studyTime (HHMMSS)", true);
  if (info.seriesNumber < 0) {
    throw std::invalid_argument(
        fmt::format("DicomSeriesInfo.seriesNumber = {} is negative", info.seriesNumber));
  }
}

/// Removes the temporary folder unless released (the series was renamed into place).
class TemporaryFolder {
 public:
  explicit TemporaryFolder(fs::path path) : path_(std::move(path)) {}
  ~TemporaryFolder() {
    if (!released_) {
      std::error_code ec;
      fs::remove_all(path_, ec);
    }
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  const fs::path& path() const { return path_; }
  void release() { released_ = true; }

 private:
  fs::path path_;
  bool released_ = false;
};

struct SeriesUids {
  std::string study;
  std::string series;
  std::string frameOfReference;
};

void writeSlice(const fs::path& file, const core::CtImage& volume, const DicomSeriesInfo& info,
                const SeriesUids& uids, int k, const std::string& groupName) {
  const auto ks = static_cast<std::size_t>(k);
  gdcm::ImageWriter writer;
  gdcm::Image& image = writer.GetImage();
  image.SetNumberOfDimensions(2);
  image.SetDimension(0, static_cast<unsigned int>(volume.dimensions[0]));
  image.SetDimension(1, static_cast<unsigned int>(volume.dimensions[1]));
  gdcm::PixelFormat format(gdcm::PixelFormat::UINT16);
  format.SetBitsStored(12);
  format.SetHighBit(11);
  image.SetPixelFormat(format);
  image.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
  image.SetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  image.SetIntercept(kRescaleIntercept);
  image.SetSlope(1.0);
  const Eigen::Vector3d first(volume.originMm.x(), volume.originMm.y(), sliceZ(volume, ks));
  image.SetOrigin(0, first.x());
  image.SetOrigin(1, first.y());
  image.SetOrigin(2, first.z());
  const double directions[6] = {1, 0, 0, 0, 1, 0};
  image.SetDirectionCosines(directions);
  image.SetSpacing(0, volume.pixelSpacingMm.x());
  image.SetSpacing(1, volume.pixelSpacingMm.y());
  image.SetSpacing(2, volume.sliceThicknessMm[ks]);

  // Stored value HU + 1024, little endian whatever the host.
  const std::size_t plane = static_cast<std::size_t>(volume.dimensions[0]) *
                            static_cast<std::size_t>(volume.dimensions[1]);
  std::vector<char> bytes(2 * plane);
  const std::size_t offset = ks * plane;
  for (std::size_t v = 0; v < plane; ++v) {
    const auto stored = static_cast<std::uint16_t>(volume.hu[offset + v] - kRescaleIntercept);
    bytes[2 * v] = static_cast<char>(stored & 0xff);
    bytes[2 * v + 1] = static_cast<char>(stored >> 8);
  }
  gdcm::DataElement pixels(gdcm::Tag(0x7fe0, 0x0010));
  pixels.SetVR(gdcm::VR::OW);
  pixels.SetByteValue(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  image.SetDataElement(pixels);

  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  const std::string instance = std::to_string(k + 1);
  setString(ds, 0x0008, 0x0008, gdcm::VR::CS, "ORIGINAL\\PRIMARY\\AXIAL");
  setString(ds, 0x0008, 0x0016, gdcm::VR::UI, kCtImageStorage);
  setString(ds, 0x0008, 0x0018, gdcm::VR::UI,
            derivedDicomUid(info.uidSeed, "dicom-instance", static_cast<std::uint64_t>(k)));
  for (const std::uint16_t element : {std::uint16_t{0x0020}, std::uint16_t{0x0021},
                                      std::uint16_t{0x0023}}) {  // study, series, content date
    setString(ds, 0x0008, element, gdcm::VR::DA, info.studyDate);
  }
  for (const std::uint16_t element : {std::uint16_t{0x0030}, std::uint16_t{0x0031},
                                      std::uint16_t{0x0033}}) {  // study, series, content time
    setString(ds, 0x0008, element, gdcm::VR::TM, info.studyTime);
  }
  setString(ds, 0x0008, 0x0050, gdcm::VR::SH, "");  // accession number
  setString(ds, 0x0008, 0x0060, gdcm::VR::CS, "CT");
  setString(ds, 0x0008, 0x0070, gdcm::VR::LO, "echoreg");
  setString(ds, 0x0008, 0x0090, gdcm::VR::PN, "");  // referring physician
  setString(ds, 0x0008, 0x1030, gdcm::VR::LO, info.studyDescription);
  setString(ds, 0x0008, 0x103e, gdcm::VR::LO, info.seriesDescription);
  setString(ds, 0x0008, 0x1090, gdcm::VR::LO, "echoreg simulated CT");
  setString(ds, 0x0010, 0x0010, gdcm::VR::PN, info.patientName);
  setString(ds, 0x0010, 0x0020, gdcm::VR::LO, info.patientId);
  setString(ds, 0x0010, 0x0030, gdcm::VR::DA, "");
  setString(ds, 0x0010, 0x0040, gdcm::VR::CS, "");
  setString(ds, 0x0018, 0x0015, gdcm::VR::CS, "LEG");
  setString(ds, 0x0018, 0x0022, gdcm::VR::CS, "HELICAL MODE");
  setString(ds, 0x0018, 0x0050, gdcm::VR::DS, decimalString(volume.sliceThicknessMm[ks]));
  setString(ds, 0x0018, 0x0060, gdcm::VR::DS, "120");
  setString(ds, 0x0018, 0x1210, gdcm::VR::SH, "BONE");
  setString(ds, 0x0018, 0x5100, gdcm::VR::CS, "FFS");
  setString(ds, 0x0020, 0x000d, gdcm::VR::UI, uids.study);
  setString(ds, 0x0020, 0x000e, gdcm::VR::UI, uids.series);
  setString(ds, 0x0020, 0x0010, gdcm::VR::SH, "1");  // study id
  setString(ds, 0x0020, 0x0011, gdcm::VR::IS, std::to_string(info.seriesNumber));
  setString(ds, 0x0020, 0x0012, gdcm::VR::IS, "1");  // acquisition number
  setString(ds, 0x0020, 0x0013, gdcm::VR::IS, instance);
  setString(ds, 0x0020, 0x0052, gdcm::VR::UI, uids.frameOfReference);
  setString(ds, 0x0020, 0x1040, gdcm::VR::LO, "");  // position reference indicator
  setString(ds, 0x0020, 0x1041, gdcm::VR::DS, decimalString(first.z()));
  setString(ds, 0x0020, 0x4000, gdcm::VR::LT, "slice group " + groupName);
  setString(ds, 0x0028, 0x0004, gdcm::VR::CS, "MONOCHROME2");
  setString(ds, 0x0028, 0x1050, gdcm::VR::DS, std::to_string(kBoneWindowCentre));
  setString(ds, 0x0028, 0x1051, gdcm::VR::DS, std::to_string(kBoneWindowWidth));
  setString(ds, 0x0028, 0x1054, gdcm::VR::LO, "HU");
  setString(ds, 0x0028, 0x1055, gdcm::VR::LO, "BONE");

  writer.SetFileName(file.string().c_str());
  if (!writer.Write())
    throw core::FileError(file.string(), "GDCM could not write this DICOM file");
}

}  // namespace

void writeDicomSeries(const std::string& folder, const core::CtImage& volume,
                      const DicomSeriesInfo& info) {
  checkInputs(volume, info);
  std::string trimmed = folder;
  while (trimmed.size() > 1 && trimmed.back() == '/')
    trimmed.pop_back();
  if (trimmed.empty())
    throw core::FileError(folder, "is an empty folder name");
  const fs::path target(trimmed);

  std::error_code ec;
  const fs::file_status status = fs::status(target, ec);
  if (fs::exists(status)) {
    if (!fs::is_directory(status))
      throw core::FileError(folder, "exists and is not a folder");
    if (!fs::is_empty(target, ec) || ec) {
      throw core::FileError(folder, "exists and is not empty: refusing to mix series");
    }
  }
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec)) {
    throw core::FileError(folder, "its parent folder " + parent.string() + " does not exist");
  }

  TemporaryFolder temporary(fs::path(trimmed + ".tmp-" + std::to_string(::getpid())));
  fs::remove_all(temporary.path(), ec);  // a leftover of an earlier crash of this process id
  if (!fs::create_directory(temporary.path(), ec) || ec) {
    throw core::FileError(folder, "cannot create the temporary folder " +
                                      temporary.path().string() + ": " +
                                      (ec ? ec.message() : std::string("it already exists")));
  }

  const SeriesUids uids{derivedDicomUid(info.uidSeed, "study"),
                        derivedDicomUid(info.uidSeed, "series"),
                        derivedDicomUid(info.uidSeed, "frame-of-reference")};
  for (std::size_t g = 0; g < volume.groups.size(); ++g) {
    // The group's name, or its number when the image names none.
    const std::string groupName =
        g < volume.groupNames.size() ? volume.groupNames[g] : std::to_string(g);
    const core::CtSliceGroup& group = volume.groups[g];
    for (int k = group.firstSlice; k < group.firstSlice + group.count; ++k) {
      const fs::path file = temporary.path() / fmt::format("IM{:06d}.dcm", k + 1);
      try {
        writeSlice(file, volume, info, uids, k, groupName);
      } catch (const core::FileError& e) {
        throw core::FileError(
            folder, fmt::format("writing {} failed: {}", file.filename().string(), e.problem()));
      }
    }
  }

  fs::rename(temporary.path(), target, ec);
  if (ec) {
    throw core::FileError(folder, "cannot rename the finished series into place: " + ec.message());
  }
  temporary.release();
}

}  // namespace echoreg::simulation
