// JSON files read with messages in the user's words (issue 15, item 13): the file named, no
// "[json.exception.parse_error.101]" codes, no "basic_filebuf::underflow" for a folder given
// where a file was expected, and a value of the wrong type named by where it sits in the file.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace echoreg::core {

/// nlohmann's message without its "[json.exception.type_error.302] " code, the overflow of a
/// number such as 1e999 said as such: "type must be string, but is null", "a number too large
/// for a double: 1e999".
std::string jsonProblem(const nlohmann::json::exception& error);

/// The JSON document in `path`. Throws FileError(path, ...) for a missing file, a folder, a file
/// that cannot be read, and a document that is not JSON ("is not valid JSON: syntax error while
/// parsing object key - unexpected end of input (line 3, column 1)"; with `kind` "markups file":
/// "is not a JSON markups file: ...").
nlohmann::json readJsonFile(const std::string& path, const std::string& kind = "");

}  // namespace echoreg::core
