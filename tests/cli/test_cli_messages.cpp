// Issue 15, item 13: messages in the user's words.
#include "cli_test_support.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace echoreg::cli {
namespace {

using test::runEchoreg;

TEST(CliMessages, AnUnknownCommandIsNamed) {
  const auto r = runEchoreg({"registr", "--out", "x.json"});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("echoreg: unknown command 'registr' (commands: "), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("register"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("A subcommand is required"), std::string::npos) << r.err;
}

// CLI11's PositiveNumber printed DBL_MAX to 300 digits and let NaN through to the core, whose
// message named its own fields (mergeDistanceMm, minRotationSpreadDeg, initialBeamToProbe).
TEST(CliMessages, NumberFlagsSayWhatTheyAcceptWithoutInternalNames) {
  // Refused before any file is read: the paths need not exist.
  const std::vector<std::tuple<std::vector<std::string>, int, std::string>> cases{
      {{"landmarks", "--merge-distance-mm", "-1"},
       2,
       "--merge-distance-mm: must be a finite number >= 0, got -1"},
      {{"landmarks", "--max-motion-mm", "0"},
       2,
       "--max-motion-mm: must be a finite number > 0, got 0"},
      {{"landmarks", "--min-duration-s", "nan"},
       2,
       "--min-duration-s: must be a finite number >= 0, got nan"},
      {{"pivot", "--min-spread-deg", "nan"},
       2,
       "--min-spread-deg: must be a number from 0 to 90, got nan"},
      {{"register", "--model", "m.vtp", "--points", "p.csv", "--initial", "i.json", "--max-rms",
        "inf"},
       2,
       "--max-rms: must be a finite number > 0, got inf"},
      {{"calibrate", "--sphere-capture", "s.mha", "--stylus-tip-to-stylus", "t.json", "--capture",
        "c.mha", "--initial", "nan", "0", "0"},
       1,
       "--initial X Y Z must be finite numbers"}};
  for (const auto& [flags, code, words] : cases) {
    std::vector<std::string> args = flags;
    if (args[0] == "landmarks")
      args.insert(args.end(), {"--capture", "c.mha", "--stylus-tip-to-stylus", "t.json",
                               "--landmarks", "l.mrk.json"});
    if (args[0] == "pivot")
      args.insert(args.end(), {"--capture", "c.mha"});
    args.insert(args.end(), {"--out", "never-written.json"});
    const auto r = runEchoreg(args);
    EXPECT_EQ(r.exitCode, code) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << "expected \"" << words << "\" in " << r.err;
    EXPECT_EQ(r.err.find("179769313"), std::string::npos) << r.err;  // DBL_MAX
    for (const char* internal : {"mergeDistanceMm", "maxMotionMm", "minDurationS",
                                 "minRotationSpreadDeg", "initialBeamToProbe"}) {
      EXPECT_EQ(r.err.find(internal), std::string::npos) << r.err;
    }
  }
  EXPECT_FALSE(std::filesystem::exists("never-written.json"));
}

}  // namespace
}  // namespace echoreg::cli
