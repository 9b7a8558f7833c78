// The DICOM CT series reader (GDCM): lists the series of a folder from their headers, and reads
// one series into a core::CtImage in Hounsfield units with its geometry taken only from
// ImagePositionPatient / ImageOrientationPatient / PixelSpacing. Slices are sorted along the slice
// normal and may be unevenly spaced (the dissertation's hip 5 mm / knee 1 mm / ankle 5 mm protocol,
// section 4.3.1): runs of equal spacing are reported as groups. Series that would give a wrong
// volume (mixed orientations, gantry tilt, duplicate or missing slices, differing sizes, truncated
// pixel data, multi-frame files) are refused with a FileError naming the folder and the files.
#pragma once

#include "echoreg/core/ct_image.hpp"

#include <functional>
#include <string>
#include <vector>

namespace echoreg::segmentation {

/// One series found in a folder (headers only).
struct DicomSeriesSummary {
  std::string seriesInstanceUid;  ///< may be empty (some exports leave it blank)
  std::string modality;           ///< "CT", "MR", ... ("" when absent)
  std::string description;        ///< SeriesDescription ("" when absent)
  int files = 0;                  ///< image files (with Rows and Columns) of the series
  int rows = 0;                   ///< of the series' first file (by name)
  int columns = 0;                ///< of the series' first file (by name)
  std::string firstFile;          ///< file name (not path) of the series' first file by name
};

/// The image series of `folder` (its regular files, not its subfolders), largest first (ties by
/// UID). Reads each file's header up to the pixel data, never the pixels. Files that GDCM cannot
/// read as DICOM, and DICOM files without an image (no Rows / Columns: DICOMDIR, RT plans...), are
/// skipped; when `warnings` is given, one line naming them (and how many) is appended to it.
/// `folder` may also be a single file. Throws FileError naming `folder` when it does not exist or
/// cannot be listed.
std::vector<DicomSeriesSummary> listDicomSeries(const std::string& folder,
                                                std::vector<std::string>* warnings = nullptr);

struct DicomReadOptions {
  /// The SeriesInstanceUID to read; empty = the CT series with the most files.
  std::string seriesUid;
  /// Called after each decoded slice with (slices done, total), from worker threads but never
  /// concurrently; an exception from it stops the read and is rethrown.
  std::function<void(int done, int total)> progress;
  /// Worker threads for scanning and decoding; 0 = std::thread::hardware_concurrency. The result
  /// is the same bytes whatever the count.
  int threads = 0;
};

/// A read series with what the reader noticed on the way.
struct DicomSeriesRead {
  core::CtImage image;
  /// File names (not paths) in slice order (image slice k came from files[k]).
  std::vector<std::string> files;
  /// The modality of the series ("CT" normally).
  std::string modality;
  /// Things worth telling the user that did not stop the read: skipped non-DICOM / non-image
  /// files, other series left out, a non-CT modality (values are then rescaled stored values, not
  /// HU), a single file without patient geometry (identity assumed)...
  std::vector<std::string> warnings;
};

/// Reads one series of `folder` (or the single DICOM file `folder`, as a one-slice image) into a
/// core::CtImage: voxels in HU (each slice's own RescaleSlope / RescaleIntercept applied to the
/// stored values of BitsStored bits, signed or not; rounded, clamped to int16); slices sorted by
/// their position along normal = row x column (of ImageOrientationPatient), k increasing along it,
/// so `direction` = [row, column, row x column] is always right-handed; originMm = the first
/// slice's ImagePositionPatient; slicePositionsMm and groups from the sorted positions (a step
/// within 1 % (or 0.01 mm) of a group's spacing continues the group). Compressed transfer syntaxes
/// are decoded by GDCM. Peak memory is the volume plus a few slices per thread. Throws FileError
/// naming `folder` and the files involved when: it does not exist or holds no readable image; there
/// is no CT series (the message lists the series found) or no series `options.seriesUid`; files
/// differ in rows, columns, pixel spacing or orientation; the slices are tilted (positions not
/// along the normal, or a non-zero GantryDetectorTilt); two slices share a position; a slice is
/// missing (a step over 1.5 x the spacing of the steps on both sides of it, when those two are
/// equal); a file is multi-frame, colour, or lacks position / orientation; the pixel data is
/// shorter than Rows x Columns x BitsAllocated, or GDCM cannot decode it.
DicomSeriesRead readDicomSeriesWithWarnings(const std::string& folder,
                                            const DicomReadOptions& options = {});

/// readDicomSeriesWithWarnings(folder, options).image.
core::CtImage readDicomSeries(const std::string& folder, const DicomReadOptions& options = {});

/// The same checks and geometry as readDicomSeriesWithWarnings from the headers only: the image
/// has its dimensions, geometry and groups but no voxels (`hu` empty). For a reader that must
/// report the extent before reading (VTK's RequestInformation). Throws as the full read does,
/// except for problems only the pixel data shows (truncation, decoding).
DicomSeriesRead readDicomSeriesGeometry(const std::string& folder,
                                        const DicomReadOptions& options = {});

}  // namespace echoreg::segmentation
