/**
 * @class   vtkEchoregDicomSeriesReader
 * @brief   Reads a DICOM CT series (echoreg::segmentation::readDicomSeries) into a vtkImageData.
 *
 * A thin adapter: the reading, sorting, checks and Hounsfield rescale are readDicomSeries's (see
 * dicom_series.hpp); this class only presents the volume to the pipeline.
 *
 * Output (port 0): vtkImageData of VTK_SHORT point scalars "HU", with origin = the centre of the
 * first voxel in CT patient coordinates (LPS, mm), spacing (column, row, slice) in mm and the
 * direction matrix (columns: row direction, column direction, slice normal), so that
 * TransformIndexToPhysicalPoint gives LPS. A vtkImageData has one slice spacing, so a series with
 * several slice groups (the dissertation's 5 mm / 1 mm / 5 mm protocol) is refused unless either
 * ResampleToUniform is on (linear resampling along k onto ResampleSpacing, default the smallest
 * step) or Group selects one group (0 = the first).
 *
 * Memory: the volume is decoded once (readDicomSeries: the volume plus a few slices) and its voxels
 * are handed to the vtkShortArray without a copy, so the peak is about 1 x the volume for a
 * uniform series. Group selection copies the group (peak: volume + group); resampling builds the
 * resampled volume (peak: volume + resampled volume).
 *
 * RequestInformation scans the headers only (readDicomSeriesGeometry) for the extent; RequestData
 * reads the pixels. Errors (missing folder, a refused series): vtkErrorMacro with the message of
 * echoreg::core::FileError (it names the folder and the files), the request fails, the output is
 * left empty and GetLastError() returns the message. Warnings of the read are in GetWarnings().
 */
#pragma once

#include "echoreg/core/ct_image.hpp"

#include <vtkImageAlgorithm.h>
#include <vtkSmartPointer.h>

#include <string>
#include <vector>

class vtkImageData;

class vtkEchoregDicomSeriesReader : public vtkImageAlgorithm {
 public:
  static vtkEchoregDicomSeriesReader* New();
  // clang-format off
  vtkTypeMacro(vtkEchoregDicomSeriesReader, vtkImageAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  /// The series folder (or one DICOM file). Default: empty (an error on update).
  void SetDirectoryName(const std::string& folder);
  const std::string& GetDirectoryName() const { return this->DirectoryName; }

  /// SeriesInstanceUID to read; empty (default) = the CT series with the most files.
  void SetSeriesUid(const std::string& uid);
  const std::string& GetSeriesUid() const { return this->SeriesUid; }

  ///@{
  /// Resample a series of several slice groups onto uniform slices (default off).
  vtkSetMacro(ResampleToUniform, bool);
  vtkGetMacro(ResampleToUniform, bool);
  vtkBooleanMacro(ResampleToUniform, bool);
  ///@}

  ///@{
  /// Slice spacing of the resampling, mm; <= 0 (default) = the smallest step between slices.
  vtkSetMacro(ResampleSpacing, double);
  vtkGetMacro(ResampleSpacing, double);
  ///@}

  ///@{
  /// Output only this slice group (0-based); -1 (default) = all slices. Ignored when resampling.
  vtkSetMacro(Group, int);
  vtkGetMacro(Group, int);
  ///@}

  /// Geometry (no voxels) of the series as read, before group selection or resampling: every slice
  /// position and group. Valid after a successful RequestInformation.
  const echoreg::core::CtImage& GetSeriesGeometry() const { return this->SeriesGeometry; }
  /// Warnings of the last read (skipped files, other series...).
  const std::vector<std::string>& GetWarnings() const { return this->Warnings; }
  /// Message of the last failure ("FOLDER: problem"), empty after a success.
  const std::string& GetLastError() const { return this->LastError; }

 protected:
  vtkEchoregDicomSeriesReader();
  ~vtkEchoregDicomSeriesReader() override;

  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
                         vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregDicomSeriesReader(const vtkEchoregDicomSeriesReader&) = delete;
  void operator=(const vtkEchoregDicomSeriesReader&) = delete;

  void Fail(const std::string& message);
  /// The output's geometry from the series' (group / resampling applied; no voxels). Throws
  /// FileError for a non-uniform series without resampling or group, or a group out of range.
  echoreg::core::CtImage OutputGeometry(const echoreg::core::CtImage& series) const;

  std::string DirectoryName;
  std::string SeriesUid;
  bool ResampleToUniform = false;
  double ResampleSpacing = 0.0;
  int Group = -1;
  echoreg::core::CtImage SeriesGeometry;
  std::vector<std::string> Warnings;
  std::string LastError;
};

namespace echoreg::segmentation {

/// The slices of group `group` (0-based) of `image` as an image of their own (origin moved to the
/// group's first slice). Copies the group's voxels when `image` has them. Throws
/// std::invalid_argument when `group` is out of range.
core::CtImage extractSliceGroup(const core::CtImage& image, int group);

/// A vtkImageData of a uniform CtImage (one slice group or one slice): VTK_SHORT scalars "HU",
/// origin, spacing and direction matrix as vtkEchoregDicomSeriesReader's output. The const
/// overload copies the voxels; the rvalue overload takes them over without a copy (the image's
/// `hu` is left empty). Throws std::invalid_argument for a non-uniform image (resample it or
/// extract a group first) or one whose `hu` does not hold dimensions' voxels.
vtkSmartPointer<vtkImageData> toImageData(const core::CtImage& image);
vtkSmartPointer<vtkImageData> toImageData(core::CtImage&& image);

}  // namespace echoreg::segmentation
