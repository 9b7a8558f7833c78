// The one check every command makes of its file arguments before any work: no output may be one
// of the command's inputs or another of its outputs (issue 15, items 1 and 9).
#pragma once

#include <string>
#include <vector>

namespace echoreg::cli {

/// A command's file arguments, each with the flag that named it. check() throws
/// std::invalid_argument naming both flags when an output resolves (std::filesystem::
/// weakly_canonical, after symbolic links; or the same file through a hard link) to an input or to
/// another output, and when a required output is an empty name. Paths of arguments not given
/// (empty) are skipped, except required outputs.
class CommandPaths {
 public:
  /// An input file or folder; skipped when empty.
  CommandPaths& input(const std::string& flag, const std::string& path);
  CommandPaths& inputs(const std::string& flag, const std::vector<std::string>& paths);
  /// An output the command must write: an empty name is refused.
  CommandPaths& output(const std::string& flag, const std::string& path);
  /// An output written only when given; skipped when empty.
  CommandPaths& optionalOutput(const std::string& flag, const std::string& path);
  /// A transform JSON and the Slicer .tfm written beside it (writeTransformFile's name).
  CommandPaths& transformOutput(const std::string& flag, const std::string& path);

  void check() const;

 private:
  struct Entry {
    std::string flag;
    std::string path;
    bool tfmOf = false;  ///< the .tfm written beside the output of `flag`
  };
  std::vector<Entry> inputs_;
  std::vector<Entry> outputs_;
};

}  // namespace echoreg::cli
