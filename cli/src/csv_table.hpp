// Small CSV tables as the commands read them (points, errors, groups): a header row of names,
// cells split at commas and trimmed, numbers checked, errors naming the file and the line.
#pragma once

#include <string>
#include <vector>

namespace echoreg::cli {

/// Splits one CSV line at commas; cells are trimmed of spaces and a trailing '\r'.
std::vector<std::string> splitCsvLine(const std::string& line);

/// A CSV table of named columns (header row first).
struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  /// Index of the column `name`, or -1.
  int column(const std::string& name) const;
};

/// Reads a whole CSV; throws FileError naming the file: not readable, empty, a row whose cell
/// count differs from the header's.
CsvTable readCsvTable(const std::string& path);

/// The number in `cell`; throws FileError "PATH: line N: column C is not a number: 'cell'".
double parseCsvNumber(const std::string& cell, const std::string& path, std::size_t line,
                      const std::string& column);

}  // namespace echoreg::cli
