#include "path_check.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace echoreg::cli {

namespace {

namespace fs = std::filesystem;

// The path a name resolves to: absolute, with its existing part's links resolved.
fs::path resolved(const std::string& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  if (ec)
    absolute = path;
  fs::path canonical = fs::weakly_canonical(absolute, ec);
  return ec ? absolute.lexically_normal() : canonical;
}

bool sameFile(const std::string& a, const std::string& b) {
  if (resolved(a) == resolved(b))
    return true;
  std::error_code ec;
  return fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec) && !ec;  // hard links
}

}  // namespace

CommandPaths& CommandPaths::input(const std::string& flag, const std::string& path) {
  if (!path.empty())
    inputs_.push_back({flag, path});
  return *this;
}

CommandPaths& CommandPaths::inputs(const std::string& flag, const std::vector<std::string>& paths) {
  for (const std::string& path : paths)
    input(flag, path);
  return *this;
}

CommandPaths& CommandPaths::output(const std::string& flag, const std::string& path) {
  if (path.empty()) {
    throw std::invalid_argument(flag + " is an empty name: give the file to write");
  }
  outputs_.push_back({flag, path});
  return *this;
}

CommandPaths& CommandPaths::optionalOutput(const std::string& flag, const std::string& path) {
  if (!path.empty())
    outputs_.push_back({flag, path});
  return *this;
}

CommandPaths& CommandPaths::transformOutput(const std::string& flag, const std::string& path) {
  output(flag, path);
  outputs_.push_back({flag, fs::path(path).replace_extension(".tfm").string(), true});
  return *this;
}

void CommandPaths::check() const {
  const auto describe = [](const Entry& e) {
    return e.tfmOf ? fmt::format("the .tfm written beside {} (\"{}\")", e.flag, e.path)
                   : fmt::format("{} \"{}\"", e.flag, e.path);
  };
  for (std::size_t i = 0; i < outputs_.size(); ++i) {
    const Entry& out = outputs_[i];
    for (const Entry& in : inputs_) {
      if (!sameFile(out.path, in.path))
        continue;
      throw std::invalid_argument(fmt::format(
          "{} is the same file as the input {} \"{}\": refusing to overwrite an input; write to "
          "another name",
          describe(out), in.flag, in.path));
    }
    for (std::size_t j = 0; j < i; ++j) {
      const Entry& other = outputs_[j];
      if (!sameFile(out.path, other.path))
        continue;
      if (out.tfmOf && out.flag == other.flag) {
        throw std::invalid_argument(fmt::format(
            "{} \"{}\" ends in .tfm: the transform JSON and the Slicer .tfm written beside it "
            "would be the same file; give {} a .json name",
            out.flag, other.path, out.flag));
      }
      throw std::invalid_argument(
          fmt::format("{} and {} are the same file: each output needs its own name",
                      describe(other), describe(out)));
    }
  }
}

}  // namespace echoreg::cli
