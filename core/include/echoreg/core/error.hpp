// Errors that name the file and the problem, so the CLI can report "FILE: problem" and exit 1.
#pragma once

#include <stdexcept>
#include <string>

namespace echoreg::core {

/// A failure tied to one file. what() reads "PATH: PROBLEM".
class FileError : public std::runtime_error {
 public:
  FileError(std::string path, std::string problem)
      : std::runtime_error(path + ": " + problem),
        path_(std::move(path)),
        problem_(std::move(problem)) {}

  const std::string& path() const noexcept { return path_; }
  const std::string& problem() const noexcept { return problem_; }

 private:
  std::string path_;
  std::string problem_;
};

}  // namespace echoreg::core
