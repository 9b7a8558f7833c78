// The simulated preoperative CT: a volume of Hounsfield units synthesised from a field of tissues
// (partial volume, tissue texture, scanner blur and noise) with the dissertation's three-group scan
// protocol (section 4.3.1), and a writer of that volume as a DICOM CT series (one file per slice).
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/simulation/tissue.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace echoreg::simulation {

/// Lowest CT number the volume holds: stored 0 of 12 bits with RescaleIntercept -1024.
inline constexpr int kCtMinHu = -1024;
/// Highest CT number the volume holds: stored 4095 of 12 bits with RescaleIntercept -1024.
inline constexpr int kCtMaxHu = 3071;

/// What lies at a point: implemented by the lead's specimen model (bones, skin, fat, muscle...).
/// synthesizeCt calls tissueAt from several threads at once, so it must be safe to call
/// concurrently (no mutable state, or state guarded by the implementation).
class TissueField {
 public:
  virtual ~TissueField() = default;
  /// The tissue at `pointCt` (CT patient coordinates, LPS, mm).
  virtual Tissue tissueAt(const Eigen::Vector3d& pointCt) const = 0;
};

/// A run of equally spaced axial slices of one protocol ("hip", "knee", "ankle").
struct CtSliceGroup {
  std::string name;        ///< "hip", "knee", "ankle"
  double firstZMm = 0.0;   ///< centre of the first slice (lowest z)
  double lastZMm = 0.0;    ///< centre of the last slice, first <= last
  double spacingMm = 1.0;  ///< distance between slice centres, also the slice thickness
};

/// How the simulated scanner images the leg: field of view, slice groups, blur and noise.
struct CtProtocol {
  int columns = 512;                 ///< pixels along +x
  int rows = 512;                    ///< pixels along +y
  double pixelSpacingMm = 0.48;      ///< in-plane pixel size (square pixels)
  Eigen::Vector2d centreXYMm{0, 0};  ///< FOV centre in CT x, y
  std::vector<CtSliceGroup> groups;  ///< in increasing z; may leave gaps between groups
  double noiseSigmaHu = 12.0;        ///< quantum noise, added after the in-plane PSF
  double psfSigmaMm = 0.35;          ///< in-plane Gaussian blur of the scanner
  int inPlaneSupersample = 3;        ///< partial-volume samples per voxel edge (interfaces)
  double zSubsampleMm = 0.5;         ///< through-slice sampling for partial volume
  /// Multiplies every tissue's hounsfieldSigma (texture); 0 gives texture-free tissue.
  double textureScale = 1.0;
  /// 1/e distance of the texture's autocorrelation exp(-d^2 / L^2) within a slice.
  double textureCorrelationMm = 1.0;
  /// Mean HU of cancellous bone instead of the tissue table's 300 (faint, osteoporotic bone:
  /// 150); NaN keeps the table's.
  double cancellousHu = std::numeric_limits<double>::quiet_NaN();
};

/// The dissertation's protocol (section 4.3.1): hip group 10 cm at 5 mm centred on `hipZ` (20
/// slices), knee group 10 cm above and below the joint line `kneeZ` at 1 mm (200 slices), ankle
/// group 10 cm at 5 mm centred on `ankleZ` (20 slices); 512 x 512 pixels of 0.48 mm (a 245.76 mm
/// field of view) centred on `centreXY`. Groups are sorted by z, whichever order the joints come
/// in. Throws std::invalid_argument when the groups would overlap.
CtProtocol dissertationProtocol(double hipZ, double kneeZ, double ankleZ, Eigen::Vector2d centreXY);

/// Small enough for unit tests: 256 x 256 pixels of 0.8 mm, knee +-80 mm at 1 mm (160 slices: the
/// small study's sweeps stay within 75 mm of the joint line, all scanned), hip
/// and ankle 3 slices at 5 mm each (centred on the joint). Same noise and blur as the full one.
CtProtocol smallProtocol(double hipZ, double kneeZ, double ankleZ, Eigen::Vector2d centreXY);

/// The geometry `protocol` gives, with no voxels (`hu` empty): an axial core::CtImage
/// (core::axialCtImage) whose slice z, thicknesses and group names are the protocol's. Throws
/// std::invalid_argument naming the offending value when the protocol is unusable (no groups,
/// non-positive sizes or spacings, slices not increasing...).
core::CtImage ctGeometry(const CtProtocol& protocol);

/// Images `field` with `protocol`. Each voxel is the mean HU of the tissues inside it: tissueAt is
/// sampled at the voxel centre on every through-slice check plane (at most 1 mm apart); where the
/// voxel or any of its 8 in-plane neighbours differs, the voxel is averaged over
/// inPlaneSupersample^2 x ceil(thickness / zSubsampleMm) points, so a 5 mm slice averages through
/// its thickness. A layer thinner than 1 mm lying between check planes of a thick slice can be
/// missed in a voxel that looks uniform. Then tissue texture (hounsfieldSigma x textureScale,
/// Gaussian-correlated over textureCorrelationMm in-plane, independent between slices, reduced by
/// sqrt(sqrt(pi) L / thickness) in slices thicker than that), then the in-plane Gaussian PSF (edges
/// replicated), then quantum noise, rounding and clamping to [kCtMinHu, kCtMaxHu].
/// Runs on hardware_concurrency threads by slices; every slice draws from its own streams
/// (Rng::derive(seed, "ct-texture" / "ct-noise", k)), so the result is the same bytes for a seed
/// whatever the thread count. `progress` (if set) is called once per finished slice with the
/// fraction done, from worker threads but never concurrently. An exception from tissueAt or
/// `progress` stops the work and is rethrown. Throws std::invalid_argument for a bad protocol.
core::CtImage synthesizeCt(const TissueField& field, const CtProtocol& protocol, std::uint64_t seed,
                           const std::function<void(double fraction)>& progress = {});

/// Patient, study and series fields of a written series. Dates and times are fixed so that the
/// same seed gives the same bytes.
struct DicomSeriesInfo {
  std::string patientName = "ECHOREG^SIMULATED";  ///< PN, at most 64 characters
  std::string patientId;                          ///< LO, at most 64 characters
  std::string studyDescription;                   ///< LO, at most 64 characters
  std::string seriesDescription;                  ///< LO, at most 64 characters
  std::string studyDate = "20081201";             ///< DA, YYYYMMDD
  std::string studyTime = "120000";               ///< TM, HHMMSS
  int seriesNumber = 1;                           ///< IS, 0..2^31-1
  /// UIDs are "2.25.<decimal of a 128-bit number derived from uidSeed>": study, series, frame of
  /// reference and every instance differ; the same uidSeed gives the same UIDs.
  std::uint64_t uidSeed = 0;
};

/// The UID "2.25.N" for the stream (uidSeed, label, index): N is a 128-bit number from
/// core::Rng::derive, written in decimal without leading zeros (at most 44 characters).
std::string derivedDicomUid(std::uint64_t uidSeed, const std::string& label,
                            std::uint64_t index = 0);

/// Writes `volume` as a CT series: one CT Image Storage file per slice, IM000001.dcm ... in slice
/// order (increasing z), explicit VR little endian, MONOCHROME2. Pixels are stored unsigned, 16
/// bits allocated, 12 stored (high bit 11), as HU + 1024 with RescaleIntercept -1024, RescaleSlope
/// 1, RescaleType HU, so the volume must lie within [kCtMinHu, kCtMaxHu]. Geometry: axial
/// ImageOrientationPatient 1\0\0\0\1\0 (the volume's direction must be the identity, its
/// pixels square), ImagePositionPatient the first pixel centre (LPS; z from sliceLocationsMm when
/// kept, else originMm.z + slicePositionsMm), PixelSpacing, SliceThickness (sliceThicknessMm, one
/// per slice, required), SliceLocation = z; ImageComments "slice group NAME" (groupNames, or the
/// group's number); KVP 120, bone window (400 / 1800). The groups must cover the slices in order.
/// Files are written into a temporary sibling folder ("FOLDER.tmp-PID") that is renamed to
/// `folder` at the end, so a failure leaves nothing behind. `folder` may exist if it is empty; its
/// parent must exist. Throws FileError naming `folder` (not writable, not empty, missing parent, a
/// write failing) or std::invalid_argument for an inconsistent volume or info.
void writeDicomSeries(const std::string& folder, const core::CtImage& volume,
                      const DicomSeriesInfo& info);

}  // namespace echoreg::simulation
