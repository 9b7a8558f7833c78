// The whole simulated study, checked from its files only: the truth it writes must agree with
// the captures, the meshes and the physics, independently of the code paths that made them.
#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/simulation/study.hpp"
#include "study_checks.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;

// One small cadaver study shared by the tests of this suite.
class SimulatedStudy : public ::testing::Test {
 protected:
  // The ctest fixture's study (ECHOREG_TEST_STUDY), or one simulated here when run alone.
  static void SetUpTestSuite() {
    root_ = fixtureStudy();
    if (!root_.empty())
      return;
    dir_ = new test::TempDir();
    root_ = dir_->file("study");
    StudyOptions options;
    options.size = StudySize::Small;
    options.seed = 7;
    generateStudy(options, root_);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string path(const std::string& relative) { return root_ + "/" + relative; }

  static test::TempDir* dir_;
  static std::string root_;
};
test::TempDir* SimulatedStudy::dir_ = nullptr;
std::string SimulatedStudy::root_;

TEST_F(SimulatedStudy, WritesTheDocumentedLayout) {
  for (const char* file :
       {"study.json", "truth/transforms.json", "truth/femur.vtp", "truth/tibia.vtp",
        "truth/fibula.vtp", "truth/shots.csv", "ct/landmarks.mrk.json",
        "captures/femur_ultrasound.igs.mha", "captures/tibia_ultrasound.igs.mha",
        "captures/calibration_shots.igs.mha", "captures/calibration_sphere_stylus.igs.mha",
        "captures/stylus_pivot.igs.mha", "captures/femur_mechanical.igs.mha",
        "captures/tibia_mechanical_blunt.igs.mha", "captures/landmarks.igs.mha",
        "captures/hip_rotation.igs.mha", "truth/captures/femur_ultrasound.igs.mha"}) {
    EXPECT_TRUE(fs::is_regular_file(path(file))) << file;
  }
  const nlohmann::json transforms = readJson(path("truth/transforms.json"));
  for (const char* key : {"BeamToProbe", "FemurToCT", "TibiaToCT", "StylusTipToStylus"}) {
    EXPECT_TRUE(transforms.contains(key)) << key;
  }
  const nlohmann::json manifest = readJson(path("study.json"));
  EXPECT_EQ(manifest.at("format"), "echoreg-study");
  EXPECT_TRUE(fs::is_regular_file(path(manifest.at("bones").at("femur").at("ultrasound").at(0))));
  // No temporary folder is left beside the study.
  for (const auto& entry : fs::directory_iterator(fs::path(root_).parent_path())) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
  }
  // Every frame of an ultrasound capture carries the three transforms; A-lines are uint8 4096.
  const core::Sequence femur = core::readSequence(path("captures/femur_ultrasound.igs.mha"));
  EXPECT_EQ(femur.elementType, core::ElementType::UInt8);
  EXPECT_EQ(femur.frameSize[0], 4096);
  for (const core::SequenceFrame& frame : femur.frames) {
    for (const char* name : {"ProbeToTracker", "FemurToTracker", "TibiaToTracker"}) {
      ASSERT_EQ(frame.transforms.count(name), 1u) << name;
    }
  }
}

// For every frame that should be accepted, the true depth turned into a point with the true
// transforms lies on the true bone surface (the contract the detector and registration rely on).
TEST_F(SimulatedStudy, TrueDepthsLandOnTheTrueSurfaces) {
  const TruthCheck check = checkTrueDepths(root_);
  std::cout << check.checked << " accepted frames checked, worst distance to the surface "
            << check.worstMm << " mm\n";
  EXPECT_GT(check.checked, 200);
  EXPECT_LT(check.worstMm, 0.05);
}

// The physics and the truth agree: the dissertation's-style detector finds the bone where the
// truth says, once the true speed of sound replaces the assumed one.
TEST_F(SimulatedStudy, DetectorFindsTheTrueDepths) {
  const std::vector<ShotRow> shots = readShots(path("truth/shots.csv"));
  for (const char* capture : {"femur_ultrasound.igs.mha", "tibia_ultrasound.igs.mha"}) {
    const core::Sequence sequence = core::readSequence(path(std::string("captures/") + capture));
    core::DetectionParams params = core::detectionPreset("default");
    params.depth = core::depthFromSequence(sequence, params.depth);
    // Frame by frame: the inter-signal filters thin a sweep, they do not judge one echo.
    params.interSignal.history = 1;
    params.interSignal.minSpreadMm = 0.0;
    const core::SequenceDetection detection = core::detectSequence(sequence, params);
    int agree = 0, total = 0, truePositive = 0, positives = 0, falsePositive = 0, negatives = 0;
    std::vector<double> errors;
    for (const ShotRow& shot : shots) {
      if (shot.capture != capture)
        continue;
      const core::FrameDetection& f = detection.frames.at(static_cast<std::size_t>(shot.frame));
      ++total;
      agree += f.accepted() == shot.shouldAccept ? 1 : 0;
      if (shot.shouldAccept) {
        ++positives;
        if (f.accepted()) {
          ++truePositive;
          errors.push_back(
              std::abs(*f.depthMm * shot.speedMps / params.depth.speedOfSoundMps - shot.depthMm));
        }
      } else {
        ++negatives;
        falsePositive += f.accepted() ? 1 : 0;
      }
    }
    std::sort(errors.begin(), errors.end());
    const double median = errors.empty() ? 1e9 : errors[errors.size() / 2];
    std::cout << capture << ": agreement " << 100.0 * agree / total << " %, sensitivity "
              << 100.0 * truePositive / std::max(1, positives) << " %, false positives "
              << 100.0 * falsePositive / std::max(1, negatives) << " %, median depth error "
              << median << " mm\n";
    EXPECT_GT(static_cast<double>(agree) / total, 0.88) << capture;
    EXPECT_LT(median, 0.3) << capture;
  }
}

TEST_F(SimulatedStudy, AcceptanceSharesPerRegionAreRealistic) {
  // Regions come from shots_detail.csv, acceptance and bones from shots.csv (same row order).
  const std::vector<ShotRow> shots = readShots(path("truth/shots.csv"));
  std::ifstream detail(path("truth/shots_detail.csv"));
  std::string line;
  std::getline(detail, line);
  struct Count {
    int frames = 0, accept = 0, fibula = 0, patella = 0;
  };
  std::map<std::string, Count> regions;
  for (const ShotRow& shot : shots) {
    ASSERT_TRUE(std::getline(detail, line));
    const auto first = line.find(',');
    const auto second = line.find(',', first + 1);
    const auto third = line.find(',', second + 1);
    ASSERT_EQ(line.substr(0, first), shot.capture);
    const std::string region = line.substr(second + 1, third - second - 1);
    Count& c = regions[region];
    ++c.frames;
    c.accept += shot.shouldAccept ? 1 : 0;
    c.fibula += shot.bone == "fibula" ? 1 : 0;
    c.patella += shot.bone == "patella" ? 1 : 0;
  }
  std::map<std::string, double> share;
  for (const auto& [region, c] : regions) {
    share[region] = static_cast<double>(c.accept) / c.frames;
    std::cout << region << ": " << c.frames << " frames, " << 100.0 * share[region]
              << " % should be accepted, " << c.fibula << " on the fibula, " << c.patella
              << " on the patella\n";
  }
  // The dissertation's difficulties: a noisy anterior femur (thick quadriceps, the patella in
  // the way), clean echoes over the subcutaneous tibia, beams landing on the fibula laterally.
  EXPECT_LT(share["anterior_distal_femur"], share["anteromedial_tibia"]);
  EXPECT_LT(share["anterior_distal_femur"], share["lateral_epicondyle"]);
  EXPECT_GT(share["anteromedial_tibia"], 0.6);
  for (const char* region :
       {"anterior_distal_femur", "medial_epicondyle", "lateral_epicondyle", "tibial_tubercle",
        "anteromedial_tibia", "medial_proximal_tibia", "lateral_proximal_tibia"}) {
    ASSERT_TRUE(share.count(region)) << region;
    EXPECT_GT(share[region], 0.05) << region;
    EXPECT_LT(share[region], 0.98) << region;
  }
  EXPECT_GT(regions["lateral_proximal_tibia"].fibula, 0) << "no lateral beam landed on the fibula";
  EXPECT_GT(regions["anterior_distal_femur"].patella, 0) << "no anterior beam met the patella";
  EXPECT_EQ(share["sphere"] > 0.8, true) << "calibration shots at the sphere are mostly clean";
}

TEST(SimulateStudy, SameSeedSameBytesAnotherSeedAnotherStudy) {
  test::TempDir dir;
  StudyOptions options;
  options.size = StudySize::Small;
  options.framesPerBone = 60;
  options.seed = 3;
  generateStudy(options, dir.file("a"));
  generateStudy(options, dir.file("b"));
  options.seed = 4;
  generateStudy(options, dir.file("c"));
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  int files = 0, differing = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir.file("a"))) {
    if (!entry.is_regular_file())
      continue;
    const fs::path relative = fs::relative(entry.path(), dir.file("a"));
    ++files;
    EXPECT_TRUE(bytes(entry.path()) == bytes(fs::path(dir.file("b")) / relative))
        << relative << " differs between two runs with the same seed";
    if (bytes(entry.path()) != bytes(fs::path(dir.file("c")) / relative))
      ++differing;
  }
  EXPECT_GT(files, 20);
  EXPECT_GT(differing, files / 2) << "another seed must give another study";
}

TEST(SimulateStudy, RefusesBadOutputsAndMeshesLeavingNothing) {
  test::TempDir dir;
  StudyOptions options;
  options.size = StudySize::Small;
  options.framesPerBone = 20;
  fs::create_directories(dir.file("full"));
  std::ofstream(dir.file("full/keep.txt")) << "mine";
  EXPECT_THROW(generateStudy(options, dir.file("full")), core::FileError);
  EXPECT_TRUE(fs::is_regular_file(dir.file("full/keep.txt")));
  EXPECT_THROW(generateStudy(options, dir.file("no/such/parent/study")), core::FileError);
  // A mesh with a hole.
  core::TriangleMesh open;
  open.vertices = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 10}};
  open.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}};
  filters::writeMesh(dir.file("open.stl"), open);
  options.meshFiles[BoneId::Femur] = dir.file("open.stl");
  try {
    generateStudy(options, dir.file("out"));
    FAIL() << "an open mesh was accepted";
  } catch (const core::FileError& e) {
    EXPECT_EQ(e.path(), dir.file("open.stl"));
  }
  EXPECT_FALSE(fs::exists(dir.file("out")));
  int leftovers = 0;
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    leftovers += entry.path().filename().string().find(".tmp-") != std::string::npos ? 1 : 0;
  }
  EXPECT_EQ(leftovers, 0);
}

// Issue 15, item 11: `simulate` interrupted by SIGINT or SIGTERM removes its OUT.tmp-PID folder
// and ends with the signal; the folders a SIGKILL leaves are swept by the next run.
TEST(SimulateStudy, SignalsRemoveTheTemporaryFolderAndStaleOnesAreSwept) {
  test::TempDir dir;
  StudyOptions options;
  options.size = StudySize::Small;
  options.framesPerBone = 20;
  for (const int number : {SIGINT, SIGTERM}) {
    const std::string out = dir.file("study-" + std::to_string(number));
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        generateStudy(options, out);
      } catch (...) {
        _exit(3);
      }
      _exit(0);
    }
    const std::string temporary = out + ".tmp-" + std::to_string(child);
    for (int waited = 0; waited < 60000 && !fs::exists(temporary + "/ct"); ++waited) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_TRUE(fs::exists(temporary)) << "the child never started writing";
    kill(child, number);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == number) << "status " << status;
    EXPECT_FALSE(fs::exists(temporary)) << "signal " << number;
    EXPECT_FALSE(fs::exists(out));
  }

  // A SIGKILLed run's folder (its process gone) is swept; a running process's is kept.
  const pid_t gone = fork();
  ASSERT_GE(gone, 0);
  if (gone == 0)
    _exit(0);
  waitpid(gone, nullptr, 0);
  const std::string out = dir.file("study");
  const std::string stale = out + ".tmp-" + std::to_string(gone);
  fs::create_directories(stale + "/ct");
  std::ofstream(stale + "/ct/slice.dcm") << "12 MB of a killed run";
  const std::string running = out + ".tmp-1";  // init runs
  fs::create_directories(running);
  options.meshFiles[BoneId::Femur] = dir.file("no-such-femur.stl");  // fails right after the sweep
  EXPECT_THROW(generateStudy(options, out), core::FileError);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(running));
}

}  // namespace
}  // namespace echoreg::simulation
