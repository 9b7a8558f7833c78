// A small document model for the study report: headings, paragraphs, tables and figures, written
// as Markdown and as a self-contained HTML page (figures linked by relative path) from one
// source, so the two never disagree.
#pragma once

#include <string>
#include <vector>

namespace echoreg::cli {

struct ReportBlock {
  enum class Kind { Heading, Paragraph, Table, Figure } kind = Kind::Paragraph;
  int level = 2;                               ///< heading level
  std::string text;                            ///< heading / paragraph text, figure caption
  std::vector<std::string> header;             ///< table
  std::vector<std::vector<std::string>> rows;  ///< table
  std::string image;                           ///< figure: path relative to the report
};

class Report {
 public:
  void heading(std::string text, int level = 2);
  void paragraph(std::string text);
  void table(std::vector<std::string> header, std::vector<std::vector<std::string>> rows);
  void figure(std::string image, std::string caption);

  std::string markdown() const;
  std::string html(const std::string& title) const;

 private:
  std::vector<ReportBlock> blocks_;
};

/// Escapes &, <, >, " for HTML text and attributes.
std::string htmlEscape(const std::string& text);

}  // namespace echoreg::cli
