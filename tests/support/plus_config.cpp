// Minimal attribute reading of PLUS XML files for tests (see plus_config.hpp).
#include "plus_config.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace echoreg::test {

namespace {

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error(path + ": cannot be read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The value of attribute `name` in the element text `tag` ("" when absent).
std::string attribute(const std::string& tag, const std::string& name) {
  std::size_t at = 0;
  while ((at = tag.find(name, at)) != std::string::npos) {
    const bool boundary = at > 0 && (tag[at - 1] == ' ' || tag[at - 1] == '\n' ||
                                     tag[at - 1] == '\t' || tag[at - 1] == '\r');
    std::size_t p = at + name.size();
    while (p < tag.size() && (tag[p] == ' ' || tag[p] == '\n' || tag[p] == '\t' || tag[p] == '\r'))
      ++p;
    if (boundary && p < tag.size() && tag[p] == '=') {
      const std::size_t open = tag.find('"', p);
      const std::size_t close = tag.find('"', open + 1);
      if (open == std::string::npos || close == std::string::npos)
        return "";
      return tag.substr(open + 1, close - open - 1);
    }
    at = p;
  }
  return "";
}

// Every element `<NAME ...>` (NAME followed by white space) in `text`, as its tag text.
std::vector<std::string> elements(const std::string& text, const std::string& name) {
  std::vector<std::string> out;
  std::size_t at = 0;
  const std::string open = "<" + name;
  while ((at = text.find(open, at)) != std::string::npos) {
    const std::size_t after = at + open.size();
    if (after < text.size() &&
        (text[after] == ' ' || text[after] == '\n' || text[after] == '\t' || text[after] == '\r')) {
      const std::size_t end = text.find('>', after);
      if (end == std::string::npos)
        break;
      out.push_back(text.substr(at, end - at + 1));
      at = end;
    } else {
      at = after;
    }
  }
  return out;
}

}  // namespace

Eigen::Matrix4d plusTransform(const std::string& path, const std::string& from,
                              const std::string& to) {
  const std::string text = readAll(path);
  for (const std::string& tag : elements(text, "Transform")) {
    if (attribute(tag, "From") != from || attribute(tag, "To") != to)
      continue;
    std::istringstream values(attribute(tag, "Matrix"));
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        if (!(values >> m(r, c)))
          throw std::runtime_error(path + ": bad Matrix of " + from + "To" + to);
      }
    }
    return m;
  }
  throw std::runtime_error(path + ": no Transform From=" + from + " To=" + to);
}

std::vector<std::pair<std::string, Eigen::Vector3d>> plusLandmarks(const std::string& path) {
  const std::string text = readAll(path);
  const std::size_t begin = text.find("<Landmarks>");
  const std::size_t end = text.find("</Landmarks>");
  if (begin == std::string::npos || end == std::string::npos || end < begin) {
    throw std::runtime_error(path + ": no <Landmarks> element");
  }
  std::vector<std::pair<std::string, Eigen::Vector3d>> out;
  for (const std::string& tag : elements(text.substr(begin, end - begin), "Landmark")) {
    std::istringstream values(attribute(tag, "Position"));
    Eigen::Vector3d p;
    if (!(values >> p.x() >> p.y() >> p.z()))
      throw std::runtime_error(path + ": bad landmark " + tag);
    out.emplace_back(attribute(tag, "Name"), p);
  }
  if (out.empty())
    throw std::runtime_error(path + ": no <Landmark> in <Landmarks>");
  return out;
}

}  // namespace echoreg::test
