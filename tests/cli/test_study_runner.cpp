// The study runner's content hash (cli/src/study_runner.hpp): the key of `study run`'s re-run
// cache, and its messages in the study's one wording, "PATH: is missing (WHY)" or "PATH: PROBLEM".
#include "study_runner.hpp"

#include "echoreg/core/error.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;

void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// The FileError `work` throws, or a failure when it throws none.
template <typename Work>
core::FileError thrownFileError(Work work) {
  try {
    work();
  } catch (const core::FileError& e) {
    return e;
  }
  ADD_FAILURE() << "no FileError thrown";
  return core::FileError("", "");
}

TEST(StudyRunnerHash, HashesAFilesBytesAndAFoldersNamesAndBytes) {
  const test::TempDir dir;
  writeText(dir.file("a.txt"), "first");
  EXPECT_EQ(contentHash(dir.file("a.txt"), "why"), bytesHash("first"));
  fs::create_directories(dir.file("folder/inner"));
  writeText(dir.file("folder/inner/b.txt"), "second");
  const std::uint64_t before = contentHash(dir.file("folder"), "why");
  // The same bytes under another name change a folder's hash; the same tree gives the same hash.
  fs::rename(dir.file("folder/inner/b.txt"), dir.file("folder/inner/c.txt"));
  const std::uint64_t renamed = contentHash(dir.file("folder"), "why");
  EXPECT_NE(renamed, before);
  EXPECT_EQ(contentHash(dir.file("folder"), "why"), renamed);
}

TEST(StudyRunnerHash, AMissingInputIsSaidWithWhyItIsNeeded) {
  const test::TempDir dir;
  const core::FileError e =
      thrownFileError([&] { contentHash(dir.file("none.igs.mha"), "step \"pivot\" needs it"); });
  EXPECT_EQ(e.path(), dir.file("none.igs.mha"));
  EXPECT_STREQ(e.what(),
               (dir.file("none.igs.mha") + ": is missing (step \"pivot\" needs it)").c_str());
}

TEST(StudyRunnerHash, AFifoIsRefusedInsteadOfBlockingTheRead) {
  const test::TempDir dir;
  ASSERT_EQ(::mkfifo(dir.file("pipe").c_str(), 0600), 0);
  const core::FileError e = thrownFileError([&] { contentHash(dir.file("pipe"), "why"); });
  EXPECT_STREQ(e.what(), (dir.file("pipe") + ": is not a regular file or a folder").c_str());
}

TEST(StudyRunnerHash, AStepsMissingInputIsNamedUnderTheStudyFolderAsTheUserNamedIt) {
  const test::TempDir dir;
  StudyRunner runner(dir.file("state.json"), false, "my-study");
  StudyStep step;
  step.id = "pivot-stylus";
  step.title = "stylus tip (pivot)";
  // Relative, as the study's steps name their inputs from inside the study folder.
  step.inputs = {"captures/no-such-capture-for-this-test.igs.mha"};
  step.action = [](const Streams&) { return 0; };
  std::ostringstream out;
  std::ostringstream err;
  const core::FileError e = thrownFileError([&] {
    runner.run(step, Streams{out, err, false}, 1, 1);
  });
  EXPECT_STREQ(e.what(),
               "my-study/captures/no-such-capture-for-this-test.igs.mha: is missing (step \"stylus "
               "tip (pivot)\" needs it)");
  EXPECT_FALSE(fs::exists(dir.file("state.json")));
}

// What a step's command said of its result on its error output (a segment's note, a register's
// warning) was dropped when the step succeeded: a study's report never showed that a bone was
// separated at a joint's sphere or that most frames were rejected. It is the step's notes, kept
// in the state, so a step that is up to date on the next run still has them; progress is not.
TEST(StudyRunner, ASucceedingStepsNotesAreKeptAndSurviveARunThatIsUpToDate) {
  const test::TempDir dir;
  writeText(dir.file("in.txt"), "input");
  int runs = 0;
  StudyStep step;
  step.id = "segment-femur";
  step.title = "femur model";
  step.command = "segment";
  step.request = "{}";
  step.inputs = {dir.file("in.txt")};
  step.outputs = {dir.file("out.txt")};
  step.action = [&](const Streams& io) {
    ++runs;
    writeText(dir.file("out.txt"), "model");
    io.err << "\rsegment: 50%\n";
    io.err << "echoreg segment: note: the femur was separated at its head's sphere\n";
    return 0;
  };
  std::ostringstream out, err;
  const Streams streams{out, err, false};
  const std::vector<std::string> expected = {
      "echoreg segment: note: the femur was separated at its head's sphere"};
  {
    StudyRunner runner(dir.file("state.json"), false);
    const StepOutcome first = runner.run(step, streams, 1, 1);
    EXPECT_EQ(first.status, StepOutcome::Status::Ran);
    EXPECT_EQ(first.notes, expected);
    runner.save();
  }
  StudyRunner again(dir.file("state.json"), false);
  const StepOutcome second = again.run(step, streams, 1, 1);
  EXPECT_EQ(second.status, StepOutcome::Status::UpToDate);
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(second.notes, expected);
  // A failing step's output is its message, not notes.
  step.id = "segment-tibia";
  step.action = [&](const Streams& io) {
    io.err << "echoreg segment: the seed is not in bone\n";
    return 1;
  };
  const StepOutcome failed = again.run(step, streams, 2, 2);
  EXPECT_EQ(failed.status, StepOutcome::Status::Failed);
  EXPECT_TRUE(failed.notes.empty());
  EXPECT_NE(failed.message.find("not in bone"), std::string::npos);
}

}  // namespace
}  // namespace echoreg::cli
