#include "report.hpp"

#include <cstdlib>
#include <sstream>

namespace echoreg::cli {

void Report::heading(std::string text, int level) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::Heading;
  b.level = level;
  b.text = std::move(text);
  blocks_.push_back(std::move(b));
}

void Report::paragraph(std::string text) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::Paragraph;
  b.text = std::move(text);
  blocks_.push_back(std::move(b));
}

void Report::table(std::vector<std::string> header, std::vector<std::vector<std::string>> rows) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::Table;
  b.header = std::move(header);
  b.rows = std::move(rows);
  blocks_.push_back(std::move(b));
}

void Report::figure(std::string image, std::string caption) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::Figure;
  b.image = std::move(image);
  b.text = std::move(caption);
  blocks_.push_back(std::move(b));
}

namespace {

std::string markdownCell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|')
      out += "\\|";
    else if (c == '\n')
      out += ' ';
    else
      out += c;
  }
  return out;
}

/// Which columns hold numbers (every cell a number, "-" or empty): those are right-aligned, so
/// that digits line up; the first column and columns of words are left-aligned.
std::vector<bool> numericColumns(const ReportBlock& table) {
  std::vector<bool> numeric(table.header.size(), true);
  if (!numeric.empty())
    numeric[0] = false;
  for (const auto& row : table.rows) {
    for (std::size_t c = 1; c < row.size() && c < numeric.size(); ++c) {
      const std::string& cell = row[c];
      if (cell.empty() || cell == "-")
        continue;
      char* end = nullptr;
      std::strtod(cell.c_str(), &end);
      if (end != cell.c_str() + cell.size())
        numeric[c] = false;
    }
  }
  return numeric;
}

}  // namespace

std::string Report::markdown() const {
  std::ostringstream md;
  for (const ReportBlock& b : blocks_) {
    switch (b.kind) {
      case ReportBlock::Kind::Heading:
        md << std::string(static_cast<std::size_t>(b.level), '#') << ' ' << b.text << "\n\n";
        break;
      case ReportBlock::Kind::Paragraph:
        md << b.text << "\n\n";
        break;
      case ReportBlock::Kind::Table: {
        md << '|';
        for (const auto& h : b.header)
          md << ' ' << markdownCell(h) << " |";
        md << "\n|";
        for (const bool numeric : numericColumns(b))
          md << (numeric ? " --: |" : " :-- |");
        md << '\n';
        for (const auto& row : b.rows) {
          md << '|';
          for (const auto& cell : row)
            md << ' ' << markdownCell(cell) << " |";
          md << '\n';
        }
        md << '\n';
        break;
      }
      case ReportBlock::Kind::Figure:
        md << "![" << markdownCell(b.text) << "](" << b.image << ")\n\n*" << b.text << "*\n\n";
        break;
    }
  }
  return md.str();
}

std::string htmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Report::html(const std::string& title) const {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>"
    << htmlEscape(title) << "</title>\n<style>\n"
    << "body{font-family:Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;"
       "color:#222;line-height:1.45}\n"
    << "table{border-collapse:collapse;margin:0.5em 0 1.5em}th,td{border:1px solid #ccc;"
       "padding:3px 9px;text-align:left}th{background:#f2f2f2}.n{text-align:right}\n"
    << "figure{margin:1em 0 2em}figure img{max-width:100%;border:1px solid #ddd}"
       "figcaption{font-style:italic;color:#555}\n</style>\n</head>\n<body>\n";
  for (const ReportBlock& b : blocks_) {
    switch (b.kind) {
      case ReportBlock::Kind::Heading:
        h << "<h" << b.level << '>' << htmlEscape(b.text) << "</h" << b.level << ">\n";
        break;
      case ReportBlock::Kind::Paragraph:
        h << "<p>" << htmlEscape(b.text) << "</p>\n";
        break;
      case ReportBlock::Kind::Table: {
        const std::vector<bool> numeric = numericColumns(b);
        auto open = [&](const char* tag, std::size_t column) {
          const bool right = column < numeric.size() && numeric[column];
          h << '<' << tag << (right ? " class=\"n\">" : ">");
        };
        h << "<table>\n<tr>";
        for (std::size_t c = 0; c < b.header.size(); ++c) {
          open("th", c);
          h << htmlEscape(b.header[c]) << "</th>";
        }
        h << "</tr>\n";
        for (const auto& row : b.rows) {
          h << "<tr>";
          for (std::size_t c = 0; c < row.size(); ++c) {
            open("td", c);
            h << htmlEscape(row[c]) << "</td>";
          }
          h << "</tr>\n";
        }
        h << "</table>\n";
        break;
      }
      case ReportBlock::Kind::Figure:
        h << "<figure><img src=\"" << htmlEscape(b.image) << "\" alt=\"" << htmlEscape(b.text)
          << "\"><figcaption>" << htmlEscape(b.text) << "</figcaption></figure>\n";
        break;
    }
  }
  h << "</body>\n</html>\n";
  return h.str();
}

}  // namespace echoreg::cli
