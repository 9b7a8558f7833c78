#include "csv_table.hpp"

#include "echoreg/core/error.hpp"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace echoreg::cli {

std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) {
    while (!cell.empty() && (cell.back() == '\r' || cell.back() == ' '))
      cell.pop_back();
    while (!cell.empty() && cell.front() == ' ')
      cell.erase(cell.begin());
    cells.push_back(cell);
  }
  if (!line.empty() && line.back() == ',')
    cells.emplace_back();
  return cells;
}

int CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name)
      return static_cast<int>(i);
  }
  return -1;
}

CsvTable readCsvTable(const std::string& path) {
  if (std::filesystem::is_directory(path))
    throw core::FileError(path, "is a directory, expected a CSV file");
  std::ifstream in(path);
  if (!in)
    throw core::FileError(path, "cannot open the CSV file");
  CsvTable table;
  std::string line;
  if (!std::getline(in, line))
    throw core::FileError(path, "is empty (no header row)");
  table.header = splitCsvLine(line);
  std::size_t lineNumber = 1;
  while (std::getline(in, line)) {
    ++lineNumber;
    if (line.empty() || line == "\r")
      continue;
    auto cells = splitCsvLine(line);
    if (cells.size() != table.header.size()) {
      throw core::FileError(path, fmt::format("line {} has {} cells, the header {}", lineNumber,
                                              cells.size(), table.header.size()));
    }
    table.rows.push_back(std::move(cells));
  }
  return table;
}

double parseCsvNumber(const std::string& cell, const std::string& path, std::size_t line,
                      const std::string& column) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(cell, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != cell.size() || !std::isfinite(value)) {
    throw core::FileError(
        path, fmt::format("line {}: column {} is not a number: '{}'", line, column, cell));
  }
  return value;
}

}  // namespace echoreg::cli
