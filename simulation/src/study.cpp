// `echoreg simulate`: a synthetic study with its ground truth (docs/simulation.md). The bones, the
// leg and the CT are made here; the captures of the protocol's steps, the truth and the manifest
// in the files study_detail.hpp names.
#include "echoreg/simulation/study.hpp"

#include "study_detail.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/simulation/ct.hpp"
#include "temporary_folder.hpp"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace echoreg::simulation {

namespace fs = std::filesystem;

using namespace detail;

std::string_view presetName(SpecimenKind kind) {
  return kind == SpecimenKind::Phantom ? "phantom" : "cadaver";
}

std::string_view standoffName(Standoff standoff) {
  switch (standoff) {
    case Standoff::GloveFinger:
      return "glove";
    case Standoff::GelPad:
      return "gel";
    case Standoff::None:
      return "none";
  }
  return "glove";
}

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

StudySummary generateStudy(const StudyOptions& options, const std::string& folder,
                           const StudyProgress& progress) {
  std::error_code ec;
  if (fs::exists(folder, ec)) {
    if (!fs::is_directory(folder, ec))
      throw core::FileError(folder, "exists and is not a folder");
    if (!fs::is_empty(folder, ec))
      throw core::FileError(folder, "exists and is not empty");
  }
  const fs::path target = fs::absolute(folder);
  const fs::path parent = target.parent_path();
  if (!fs::is_directory(parent, ec)) {
    throw core::FileError(folder, "its parent folder " + parent.string() + " does not exist");
  }
  if (!(options.underSkinScale > 0.0 && options.underSkinScale <= 1.0)) {
    throw std::invalid_argument("soft tissue scale must be in (0, 1], got " +
                                std::to_string(options.underSkinScale));
  }
  if (!(options.osteophyteMm >= 0.0 && options.osteophyteMm <= 8.0)) {
    throw std::invalid_argument("osteophytes must be within 0 to 8 mm, got " +
                                std::to_string(options.osteophyteMm));
  }
  if (options.osteophyteMm > 0.0 && options.meshFiles.count(BoneId::Femur) != 0) {
    throw std::invalid_argument(
        "osteophytes need the procedural femur (they are grown on its shape), not a mesh file");
  }
  if (options.probeFrequencyHz != 0.0 &&
      !(options.probeFrequencyHz >= 1e6 && options.probeFrequencyHz <= 20e6)) {
    throw std::invalid_argument("probe frequency must be in [1, 20] MHz, got " +
                                std::to_string(options.probeFrequencyHz) + " Hz");
  }
  // Sweeps the stale temporary folders of killed runs; this one's is removed on any early end.
  TemporaryFolder cleanup(target);
  for (const auto& [bone, file] : options.meshFiles) {
    (void)bone;
    if (!fs::is_regular_file(file, ec))
      throw core::FileError(file, "no such mesh file");
  }
  const fs::path temporary = cleanup.path();
  for (const char* sub : {"", "/ct", "/captures", "/truth", "/truth/captures"}) {
    fs::create_directories(temporary.string() + sub, ec);
    if (ec)
      throw core::FileError(temporary.string() + sub, "cannot create folder: " + ec.message());
  }
  const std::string root = temporary.string();
  const Sizes sizes = sizesFor(options);
  StudySummary summary;
  summary.folder = target.string();
  auto report = [&](const std::string& step, double fraction) {
    if (progress)
      progress(step, fraction);
  };

  // Bones.
  auto stepStart = Clock::now();
  report("bones", 0.0);
  KneeOptions kneeOptions;
  kneeOptions.flexionDeg = options.flexionDeg;
  kneeOptions.meshResolutionMm = sizes.meshResolutionMm;
  kneeOptions.seed = options.seed;
  kneeOptions.meshFiles = options.meshFiles;
  kneeOptions.osteophyteMm = options.osteophyteMm;
  Knee knee = buildKnee(kneeOptions);
  summary.stepSeconds.push_back({"bones", secondsSince(stepStart)});

  // Leg.
  stepStart = Clock::now();
  SoftTissueOptions tissue;
  tissue.thicknessScale = options.tissueScale;
  tissue.underSkinScale = options.underSkinScale;
  tissue.seed = options.seed;
  const Specimen specimen(knee, options.preset, tissue, [&](double f) { report("leg", f); });
  summary.stepSeconds.push_back({"leg", secondsSince(stepStart)});

  // Captures.
  stepStart = Clock::now();
  StudyBuilder builder(options, specimen, root, progress);
  builder.writeCaptures(summary);
  summary.stepSeconds.push_back({"captures", secondsSince(stepStart)});

  // CT.
  stepStart = Clock::now();
  const Eigen::Vector2d centre =
      (0.5 * (knee.hipCentre + knee.kneeCentre)).head<2>() * 0.5 + knee.kneeCentre.head<2>() * 0.5;
  const CtProtocol protocol =
      options.size == StudySize::Small
          ? smallProtocol(knee.hipCentre.z(), knee.kneeCentre.z(), knee.ankleCentre.z(), centre)
          : dissertationProtocol(knee.hipCentre.z(), knee.kneeCentre.z(), knee.ankleCentre.z(),
                                 centre);
  const core::CtImage volume =
      synthesizeCt(specimen, protocol, options.seed, [&](double f) { report("ct", f); });
  DicomSeriesInfo dicom;
  dicom.patientId = fmt::format("ECHOREG-{}-{}", presetName(options.preset), options.seed);
  dicom.studyDescription = fmt::format("echoreg simulated {} study", presetName(options.preset));
  dicom.seriesDescription = "Leg CT: hip 5 mm, knee 1 mm, ankle 5 mm";
  dicom.uidSeed = core::Rng::derive(options.seed, presetName(options.preset),
                                    options.size == StudySize::Small ? 1 : 2)
                      .next();
  writeDicomSeries(root + "/ct/series", volume, dicom);
  writeMarkups(root + "/ct/landmarks.mrk.json", builder.ctLandmarks());
  summary.ctSlices = volume.dimensions[2];
  summary.ctSize = {volume.dimensions[0], volume.dimensions[1]};
  summary.stepSeconds.push_back({"ct", secondsSince(stepStart)});

  // Truth.
  stepStart = Clock::now();
  writeTruth(root, options, knee, builder);
  summary.stepSeconds.push_back({"truth", secondsSince(stepStart)});

  // Manifest.
  writeManifest(root, options, knee, builder);

  // Publish.
  if (fs::exists(target, ec))
    fs::remove(target, ec);  // empty (checked above)
  fs::rename(temporary, target, ec);
  if (ec)
    throw core::FileError(folder, "could not be written: " + ec.message());
  cleanup.published();
  return summary;
}

}  // namespace echoreg::simulation