#include "echoreg/core/json_file.hpp"

#include "echoreg/core/error.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace echoreg::core {

std::string jsonProblem(const nlohmann::json::exception& error) {
  std::string text = error.what();
  // "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error ..."
  if (!text.empty() && text.front() == '[') {
    const std::size_t close = text.find("] ");
    if (close != std::string::npos)
      text.erase(0, close + 2);
  }
  constexpr const char* kOverflow = "number overflow parsing '";
  if (const std::size_t at = text.find(kOverflow); at != std::string::npos) {
    const std::size_t start = at + std::strlen(kOverflow);
    const std::size_t end = text.find('\'', start);
    return "a number too large for a double: " +
           text.substr(start, end == std::string::npos ? std::string::npos : end - start);
  }
  const std::string parsePrefix = "parse error at ";
  if (text.compare(0, parsePrefix.size(), parsePrefix) == 0) {
    // "parse error at line 3, column 1: syntax error while parsing ..." -> the problem first.
    const std::size_t colon = text.find(": ");
    if (colon != std::string::npos) {
      return text.substr(colon + 2) + " (" +
             text.substr(parsePrefix.size(), colon - parsePrefix.size()) + ")";
    }
  }
  return text;
}

nlohmann::json readJsonFile(const std::string& path, const std::string& kind) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw FileError(path, "is a folder, expected a JSON file");
  if (!std::filesystem::exists(path, ec))
    throw FileError(path, "no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw FileError(path, std::string("cannot be opened: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad())
    throw FileError(path, "cannot be read");
  if (text.str().find_first_not_of(" \t\r\n") == std::string::npos)
    throw FileError(path, "is empty, expected a JSON document");
  try {
    return nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::exception& e) {
    throw FileError(
        path, (kind.empty() ? std::string("is not valid JSON: ") : "is not a JSON " + kind + ": ") +
                  jsonProblem(e));
  }
}

}  // namespace echoreg::core
