// Bone models read for a command (issue 15, items 8 and 13): VTK's readers say nothing of a
// vertex that is not a number (an OBJ's "v nan 0 0" became a spike in the model and the figure)
// and print their own coloured log lines before our one-line message, so both are handled here.
#pragma once

#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/filters/mesh_io.h"

#include <vtkObject.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace echoreg::cli {

/// VTK 9.1's OBJ reader turns a coordinate that is not a finite number ("nan", "inf", "1e999",
/// "x") into a finite one without a word, and passes a face's vertex number beyond the vertices on
/// to VTK's triangle filter, which reads out of bounds (a crash, found by fuzz/fuzz_mesh). So the
/// vertex and face lines are checked in the text: throws FileError naming the line. A line is
/// read as VTK reads it: white space (any of isspace's) before its keyword and after it, so an
/// indented " f 1 2 3" is a face (it went unchecked: found by fuzz/fuzz_mesh).
inline void checkObjFile(const std::string& path) {
  std::vector<std::string> lines;
  {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && line.back() == '\r')
        line.pop_back();
      lines.push_back(line);
    }
  }
  const auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  // The line's keyword is `kind` ("v", "vt", "f"...; after any white space), followed by white
  // space; `rest` is what follows the keyword.
  const auto starts = [&space](const std::string& line, std::string_view kind, std::string& rest) {
    const auto keyword = std::find_if_not(line.begin(), line.end(), space);
    const auto size = static_cast<std::ptrdiff_t>(kind.size());
    if (line.end() - keyword <= size || !std::equal(kind.begin(), kind.end(), keyword) ||
        !space(keyword[size]))
      return false;
    rest.assign(keyword + size, line.end());
    return true;
  };
  std::string rest;
  long long vertices = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (!starts(lines[i], "v", rest))
      continue;  // not a vertex position (vn, vt, f, comments, ...)
    ++vertices;
    std::istringstream words(rest);
    std::string word;
    for (int axis = 0; axis < 3; ++axis) {
      double value = 0.0;
      const bool read = static_cast<bool>(words >> word);
      const char* end = word.data() + word.size();
      const auto parsed =
          read ? std::from_chars(word.data(), end, value) : std::from_chars_result{};
      if (!read || parsed.ec != std::errc() || parsed.ptr != end || !std::isfinite(value)) {
        throw core::FileError(path,
                              fmt::format("line {}: vertex {} \"{}\" is not three finite numbers: "
                                          "a damaged model (a NaN or infinite coordinate)",
                                          i + 1, vertices, lines[i]));
      }
    }
  }
  // Texture coordinates and normals a face may name after its vertex ("7/1", "7//3", "7/1/3"):
  // VTK's reader reads a number beyond them out of bounds too (a crash, found by fuzz/fuzz_mesh).
  long long texture = 0, normals = 0;
  for (const std::string& line : lines) {
    texture += starts(line, "vt", rest) ? 1 : 0;
    normals += starts(line, "vn", rest) ? 1 : 0;
  }
  // `number` is a whole number from 1 to `count`, or from -1 to -count (from the end).
  const auto isIndex = [](const std::string& number, long long count) {
    long long index = 0;
    const auto parsed = std::from_chars(number.data(), number.data() + number.size(), index);
    return parsed.ec == std::errc() && parsed.ptr == number.data() + number.size() && index != 0 &&
           index <= count && index >= -count;
  };
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (!starts(lines[i], "f", rest))
      continue;
    std::istringstream words(rest);
    std::string word;
    int corners = 0;
    while (words >> word) {
      // "7", "7/1", "7//3", "7/1/3": the vertex number comes first; negative counts from the end.
      const std::size_t slash = word.find('/');
      if (!isIndex(word.substr(0, slash), vertices)) {
        throw core::FileError(path,
                              fmt::format("line {}: face \"{}\": \"{}\" is not a vertex number "
                                          "from 1 to {}",
                                          i + 1, lines[i], word, vertices));
      }
      if (slash != std::string::npos) {
        const std::size_t second = word.find('/', slash + 1);
        const std::string uv = word.substr(
            slash + 1, second == std::string::npos ? std::string::npos : second - slash - 1);
        const std::string normal =
            second == std::string::npos ? std::string() : word.substr(second + 1);
        // "7/": a slash and nothing after it, in none of OBJ's forms; VTK's reader then reads a
        // texture coordinate of a file with none (a crash, found by fuzz/fuzz_mesh).
        if (uv.empty() && normal.empty()) {
          throw core::FileError(
              path, fmt::format("line {}: face \"{}\": \"{}\" is not a corner (a vertex number, "
                                "then /texture, //normal or /texture/normal)",
                                i + 1, lines[i], word));
        }
        if ((!uv.empty() && !isIndex(uv, texture)) ||
            (!normal.empty() && !isIndex(normal, normals))) {
          throw core::FileError(
              path, fmt::format("line {}: face \"{}\": \"{}\" names a texture coordinate or "
                                "normal the file does not have ({} texture coordinates, {} "
                                "normals)",
                                i + 1, lines[i], word, texture, normals));
        }
      }
      ++corners;
    }
    if (corners < 3)
      throw core::FileError(
          path, fmt::format("line {}: face \"{}\" has fewer than 3 corners", i + 1, lines[i]));
  }
}

namespace detail {

/// One binary PLY value of `type` (a PLY type name) from `in`; false at the end of the file.
inline bool readBinaryValue(std::istream& in, const std::string& type, bool bigEndian,
                            double& value) {
  const auto is = [&](std::initializer_list<const char*> names) {
    return std::any_of(names.begin(), names.end(), [&](const char* n) { return type == n; });
  };
  const std::size_t size = is({"char", "uchar", "int8", "uint8"})       ? 1
                           : is({"short", "ushort", "int16", "uint16"}) ? 2
                           : is({"double", "float64"})                  ? 8
                                                                        : 4;
  unsigned char bytes[8] = {};
  if (!in.read(reinterpret_cast<char*>(bytes), static_cast<std::streamsize>(size)))
    return false;
  if (bigEndian)
    std::reverse(bytes, bytes + size);  // to the little-endian order of the machines we build for
  std::uint64_t bits = 0;
  for (std::size_t b = 0; b < size; ++b)
    bits |= static_cast<std::uint64_t>(bytes[b]) << (8 * b);
  const bool isSigned = is({"char", "int8", "short", "int16", "int", "int32"});
  if (is({"float", "float32"})) {
    float f = 0.0f;
    const auto narrow = static_cast<std::uint32_t>(bits);
    std::memcpy(&f, &narrow, sizeof f);
    value = f;
  } else if (size == 8) {
    std::memcpy(&value, &bits, sizeof value);
  } else if (isSigned) {
    const std::uint64_t sign = std::uint64_t{1} << (8 * size - 1);
    value = static_cast<double>(static_cast<std::int64_t>((bits ^ sign) - sign));
  } else {
    value = static_cast<double>(bits);
  }
  return true;
}

}  // namespace detail

/// VTK 9.1's PLY reader crashes (a null pointer; found by fuzz/fuzz_mesh) on a header line it does
/// not know ("propert} float z") and on an ASCII data line with too few numbers, leaks what it read
/// of a header with a second format line, and reads faces naming vertices beyond the file out of
/// bounds, so the file is checked first: the header's keywords, one known format, each element's
/// count, an end, the vertex and face elements a model needs, then the data against the header's
/// properties (in an ASCII file line by line, in a binary one value by value): present in full,
/// every face's corners vertices of the file. Throws FileError naming the line (or the element and
/// row of binary data).
inline void checkPlyFile(const std::string& path) {
  struct Element {
    std::string name;
    std::size_t line = 0;  ///< of its declaration in the header
    std::uint64_t count = 0;
    std::vector<bool> list;  ///< per property: a list (a count, then that many values)
    std::vector<std::string> names;
    std::vector<std::string> types;       ///< per property: its type (a list's: its items' type)
    std::vector<std::string> countTypes;  ///< per property: a list's count type ("" otherwise)
  };
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t lineNumber = 0;
  bool ascii = false;
  bool bigEndian = false;
  int formats = 0;
  std::vector<Element> elements;
  const auto refuse = [&](const std::string& problem) {
    throw core::FileError(
        path, fmt::format("line {}: {} (not a PLY file as VTK reads it)", lineNumber, problem));
  };
  const auto number = [](const std::string& word, double& value) {
    const auto parsed = std::from_chars(word.data(), word.data() + word.size(), value);
    return parsed.ec == std::errc() && parsed.ptr == word.data() + word.size();
  };
  bool ended = false;
  while (!ended && std::getline(in, line)) {
    ++lineNumber;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (lineNumber > 10000)
      refuse("no end_header in the first 10000 lines");
    // VTK splits header lines at NUL bytes and then reads past the words it found (a crash).
    if (!std::all_of(line.begin(), line.end(), [](char c) {
          const auto u = static_cast<unsigned char>(c);
          return (u >= 32 && u < 127) || c == '\t';
        }))
      refuse("the header holds a byte that is not printable text");
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (lineNumber == 1) {
      if (keyword != "ply")
        refuse("the file does not start with \"ply\"");
    } else if (keyword == "end_header") {
      ended = true;
    } else if (keyword == "format") {
      // VTK leaks what it read of a header with a second format line (LeakSanitizer, fuzz_mesh).
      std::string kind;
      words >> kind;
      if (++formats > 1)
        refuse("a second format line");
      if (kind != "ascii" && kind != "binary_little_endian" && kind != "binary_big_endian")
        refuse("\"" + line +
               "\" is not \"format ascii|binary_little_endian|binary_big_endian 1.0\"");
      ascii = kind == "ascii";
      bigEndian = kind == "binary_big_endian";
    } else if (keyword == "comment" || keyword == "obj_info") {
    } else if (keyword == "element") {
      Element element;
      std::string count, extra;
      words >> element.name >> count;
      double n = 0.0;
      if (element.name.empty() || !number(count, n) || n < 0 || n != std::floor(n) ||
          (words >> extra))
        refuse("\"" + line + "\" is not \"element NAME COUNT\"");
      // VTK keeps a count in an int; a larger one (1e62 from fuzz/fuzz_mesh) is not a count of
      // rows, nor convertible to one.
      if (n > 2147483647.0)
        refuse(fmt::format("element {} claims {} rows, more than VTK's PLY reader can count",
                           element.name, count));
      element.count = static_cast<std::uint64_t>(n);
      element.line = lineNumber;
      elements.push_back(element);
    } else if (keyword == "property") {
      static const std::vector<std::string> kTypes{
          "char", "uchar", "short", "ushort", "int",   "uint",   "float",   "double",
          "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
      const auto known = [](const std::string& type) {
        return std::find(kTypes.begin(), kTypes.end(), type) != kTypes.end();
      };
      std::string type, name;
      words >> type >> name;
      if (name.empty() || elements.empty() || (type != "list" && !known(type)))
        refuse("\"" + line +
               "\" is not \"property TYPE NAME\" of an element (TYPE: char, "
               "uchar, short, ushort, int, uint, float, double or their sized names)");
      elements.back().list.push_back(type == "list");
      std::string countType;
      if (type == "list") {
        countType = name;
        name.clear();
        words >> type >> name;
        if (name.empty() || !known(countType) || !known(type))
          refuse("\"" + line + "\" is not \"property list COUNT_TYPE TYPE NAME\"");
      }
      elements.back().names.push_back(name);
      elements.back().types.push_back(type);
      elements.back().countTypes.push_back(countType);
    } else {
      refuse("\"" + line +
             "\" is not a PLY header line (format, comment, obj_info, element, "
             "property, end_header)");
    }
  }
  if (!ended)
    refuse("the header has no end_header");
  const auto has = [&](const char* name) {
    return std::any_of(elements.begin(), elements.end(),
                       [&](const Element& e) { return e.name == name; });
  };
  if (!has("vertex") || !has("face"))
    refuse("the header declares no " + std::string(has("vertex") ? "face" : "vertex") + " element");
  // VTK 9.1 frees, closing the file, memory it never allocated for an element with no properties,
  // wherever it is declared (a crash in vtkPLY::ply_close, found by fuzz/fuzz_mesh).
  for (const Element& element : elements) {
    if (element.list.empty()) {
      lineNumber = element.line;
      refuse("element " + element.name +
             " has no properties: VTK's PLY reader crashes on such an element");
    }
  }
  // VTK reads the vertices' x, y, z and the faces' vertex_indices (it crashed on another name).
  for (const Element& element : elements) {
    const auto named = [&](const char* name) {
      return std::find(element.names.begin(), element.names.end(), name) != element.names.end();
    };
    if (element.name == "vertex" && !(named("x") && named("y") && named("z")))
      refuse("the vertex element has no x, y and z properties");
    // A vertex_indices that is not a list: VTK frees a list it never allocated (a crash in
    // vtkPLYReader::RequestData, found by fuzz/fuzz_mesh).
    const auto indices = std::find(element.names.begin(), element.names.end(), "vertex_indices");
    if (element.name == "face" &&
        (indices == element.names.end() ||
         !element.list[static_cast<std::size_t>(indices - element.names.begin())]))
      refuse("the face element has no vertex_indices list");
  }
  if (formats == 0)
    refuse("the header has no format line");
  // VTK reads the vertex and face elements and skips no other: the rows of another element before
  // either were read as vertices or faces (a crash in vtkPLYReader, found by fuzz/fuzz_mesh), and
  // a second vertex or face element is read over the first.
  {
    const std::size_t endHeader = lineNumber;
    std::size_t lastRead = 0;  // the later of the vertex and face elements
    for (std::size_t e = 0; e < elements.size(); ++e)
      lastRead = elements[e].name == "vertex" || elements[e].name == "face" ? e : lastRead;
    int vertexElements = 0, faceElements = 0;
    for (std::size_t e = 0; e < elements.size(); ++e) {
      const Element& element = elements[e];
      const bool read = element.name == "vertex" || element.name == "face";
      lineNumber = element.line;
      if (read && ++(element.name == "vertex" ? vertexElements : faceElements) > 1)
        refuse("a second " + element.name + " element");
      if (!read && e < lastRead && element.count > 0 && !element.list.empty()) {
        refuse(
            fmt::format("element {} ({} rows) comes before the {} element: VTK reads only the "
                        "vertex and face elements and would read its rows as theirs",
                        element.name, element.count, elements[lastRead].name));
      }
    }
    lineNumber = endHeader;  // the data's lines are counted on from here
  }
  std::uint64_t vertexCount = 0;
  for (const Element& element : elements) {
    if (element.name == "vertex") {
      vertexCount = element.count;
      // No vertices: nothing to register, and VTK 9.1's PLY reader frees memory it never
      // allocated when a face row of such a file holds more than its list (found by
      // fuzz/fuzz_mesh).
      if (vertexCount == 0) {
        lineNumber = element.line;
        refuse("the vertex element has no rows");
      }
    }
  }
  // VTK reads an ASCII list it does not use (any list of the vertex and face elements but the
  // faces' vertex_indices and texcoord) with an item size it never set: a crash in
  // vtkPLY::ascii_get_element, found by fuzz/fuzz_mesh (stop 33). Binary files skip such lists.
  if (ascii) {
    for (const Element& element : elements) {
      if (element.name != "vertex" && element.name != "face")
        continue;
      for (std::size_t p = 0; p < element.list.size(); ++p) {
        const bool used = element.name == "face" &&
                          (element.names[p] == "vertex_indices" || element.names[p] == "texcoord");
        if (element.list[p] && !used) {
          lineNumber = element.line;
          refuse(
              fmt::format("element {} has a list property {} that VTK does not read: VTK's "
                          "PLY reader crashes on such a list in an ASCII file",
                          element.name, element.names[p]));
        }
      }
    }
  }
  if (!ascii) {
    // Value by value: each list's count, then its items; the file must hold every row, and a
    // face's corners must be vertices (VTK reads faces beyond the vertices out of bounds).
    for (const Element& element : elements) {
      if (element.list.empty())
        continue;  // no properties: no bytes, whatever the count
      for (std::uint64_t row = 0; row < element.count; ++row) {
        for (std::size_t p = 0; p < element.list.size(); ++p) {
          const auto refuseData = [&](const std::string& problem) {
            throw core::FileError(path,
                                  "binary data: " + problem + " (not a PLY file as VTK reads it)");
          };
          const auto truncated = [&] {
            refuseData(fmt::format("the file ends within element {} (row {} of {})", element.name,
                                   row + 1, element.count));
          };
          double items = 1.0;
          if (element.list[p]) {
            if (!detail::readBinaryValue(in, element.countTypes[p], bigEndian, items))
              truncated();
            if (!(items >= 0 && items == std::floor(items)))
              refuseData(fmt::format("element {} row {} has a list of {} items", element.name,
                                     row + 1, items));
          }
          const bool corners = element.name == "face" && element.names[p] == "vertex_indices";
          for (double k = 0; k < items; ++k) {
            double item = 0.0;
            if (!detail::readBinaryValue(in, element.types[p], bigEndian, item))
              truncated();
            if (corners && !(item >= 0 && item < static_cast<double>(vertexCount)))
              refuseData(fmt::format("face {} names vertex {}, not one from 0 to {}", row + 1, item,
                                     static_cast<double>(vertexCount) - 1));
          }
        }
      }
    }
    return;
  }
  for (const Element& element : elements) {
    for (std::uint64_t row = 0; row < element.count; ++row) {
      ++lineNumber;
      if (!std::getline(in, line))
        refuse(fmt::format("the file ends within element {} ({} of {} lines)", element.name, row,
                           element.count));
      std::istringstream words(line);
      std::string word;
      double value = 0.0;
      for (std::size_t p = 0; p < element.list.size(); ++p) {
        if (!(words >> word) || !number(word, value))
          refuse(fmt::format("element {}: \"{}\" has too few numbers", element.name, line));
        // A face's corners must be vertices of the file (VTK read beyond them: a crash).
        const bool corners = element.name == "face" && element.names[p] == "vertex_indices";
        for (double k = 0; element.list[p] && k < value; ++k) {
          double item = 0.0;
          if (!(words >> word) || !number(word, item))
            refuse(fmt::format("element {}: \"{}\" has too few numbers", element.name, line));
          if (corners && !(item >= 0 && item < static_cast<double>(vertexCount)))
            refuse(fmt::format("face \"{}\": {} is not a vertex number from 0 to {}", line, word,
                               static_cast<double>(vertexCount) - 1));
        }
      }
    }
  }
}

/// VTK 9.1's ASCII STL reader says only "holds no triangles" for a file with one malformed facet
/// (a fourth vertex, a missing number, no endsolid), and reads "nan" as a number, so the text is
/// checked first: solid, then facets of "facet normal N N N", "outer loop", three "vertex X Y Z"
/// of finite numbers, "endloop", "endfacet", then endsolid (another solid may follow). Throws
/// FileError naming the line and what was expected there.
inline void checkAsciiStl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t lineNumber = 0;
  // What comes next, in order; "vertex" three times.
  static const std::vector<std::string> kFacet{"facet",  "outer",   "vertex",  "vertex",
                                               "vertex", "endloop", "endfacet"};
  std::size_t step = 0;  // within kFacet
  bool inSolid = false;  // after "solid", before "endsolid"
  const auto refuse = [&](const std::string& expected) {
    const std::string found = in ? "\"" + line + "\"" : "the end of the file";
    throw core::FileError(
        path, fmt::format("line {}: expected {}, found {} (not an ASCII STL file as VTK "
                          "reads it)",
                          lineNumber, expected, found));
  };
  // `count` numbers and nothing else; finite ones for vertices (exporters write "nan" normals of
  // degenerate facets, which VTK ignores).
  const auto numbers = [](std::istringstream& words, int count, bool finite) {
    std::string word;
    for (int i = 0; i < count; ++i) {
      double value = 0.0;
      if (!(words >> word))
        return false;
      const auto parsed = std::from_chars(word.data(), word.data() + word.size(), value);
      if (parsed.ec != std::errc() || parsed.ptr != word.data() + word.size() ||
          (finite && !std::isfinite(value)))
        return false;
    }
    return !(words >> word);
  };
  while (std::getline(in, line)) {
    ++lineNumber;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    if (!(words >> keyword))
      continue;  // a blank line
    std::transform(keyword.begin(), keyword.end(), keyword.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (!inSolid) {
      if (keyword != "solid")
        refuse("\"solid NAME\"");
      inSolid = true;
      continue;
    }
    if (step == 0 && keyword == "endsolid") {
      inSolid = false;
      continue;
    }
    if (keyword != kFacet[step])
      refuse(step == 0 ? "\"facet normal NX NY NZ\" or \"endsolid\"" : "\"" + kFacet[step] + "\"");
    std::string word;
    if (keyword == "facet" && !((words >> word) && word == "normal" && numbers(words, 3, false)))
      refuse("\"facet normal NX NY NZ\"");
    if (keyword == "outer" && !((words >> word) && word == "loop" && !(words >> word)))
      refuse("\"outer loop\"");
    if (keyword == "vertex" && !numbers(words, 3, true))
      refuse("\"vertex X Y Z\" of three finite numbers (a triangle's facet has three)");
    step = (step + 1) % kFacet.size();
  }
  if (inSolid) {
    ++lineNumber;
    refuse(step == 0 ? "\"endsolid\"" : "\"" + kFacet[step] + "\"");
  }
}

/// VTK 9.1's STL reader allocates what a binary STL's header claims (the triangle count at byte 80)
/// before reading: 13.9 GB for a 295-byte file (found by fuzz/fuzz_mesh). A file that is not plain
/// ASCII text must be exactly 84 + 50 x count bytes. Throws FileError saying what the header
/// claims.
inline void checkStlSize(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size == 0)
    return;  // readMesh names the problem ("holds no triangles")
  std::ifstream in(path, std::ios::binary);
  std::string head(static_cast<std::size_t>(std::min<std::uintmax_t>(size, 4096)), '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  const bool text =
      head.rfind("solid", 0) == 0 && std::all_of(head.begin(), head.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return (u >= 32 && u < 127) || c == '\n' || c == '\r' || c == '\t';
      });
  if (text) {
    checkAsciiStl(path);
    return;
  }
  if (size < 84)
    throw core::FileError(
        path, fmt::format("a binary STL of {} bytes, shorter than its 84-byte header", size));
  const auto count = static_cast<std::uint32_t>(static_cast<unsigned char>(head[80])) |
                     static_cast<std::uint32_t>(static_cast<unsigned char>(head[81])) << 8 |
                     static_cast<std::uint32_t>(static_cast<unsigned char>(head[82])) << 16 |
                     static_cast<std::uint32_t>(static_cast<unsigned char>(head[83])) << 24;
  const std::uintmax_t needed = 84 + 50 * static_cast<std::uintmax_t>(count);
  if (needed != size) {
    throw core::FileError(path,
                          fmt::format("a binary STL whose header counts {} triangles ({} bytes), "
                                      "but the file holds {} bytes: truncated or not an STL",
                                      count, needed, size));
  }
}

/// filters::readMesh(path) with VTK's own warnings and errors kept off stderr (the FileError that
/// follows names the file and the problem), refusing a model with a vertex that is not finite.
inline core::TriangleMesh readModelFile(const std::string& path) {
  struct QuietVtk {
    int was = vtkObject::GetGlobalWarningDisplay();
    QuietVtk() { vtkObject::GlobalWarningDisplayOff(); }
    ~QuietVtk() { vtkObject::SetGlobalWarningDisplay(was); }
  };
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj" && std::filesystem::is_regular_file(path))
    checkObjFile(path);
  if (extension == ".ply" && std::filesystem::is_regular_file(path))
    checkPlyFile(path);
  if (extension == ".stl" && std::filesystem::is_regular_file(path))
    checkStlSize(path);
  core::TriangleMesh mesh;
  {
    const QuietVtk quiet;
    mesh = filters::readMesh(path);
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d& v = mesh.vertices[i];
    if (!v.allFinite()) {
      throw core::FileError(path, fmt::format("vertex {} of {} is not a finite point ({} {} {}): a "
                                              "damaged model (a NaN or infinite coordinate)",
                                              i + 1, mesh.vertices.size(), v.x(), v.y(), v.z()));
    }
  }
  return mesh;
}

}  // namespace echoreg::cli
