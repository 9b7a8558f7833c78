// Statistics of the reports: box-plot summaries and the one-way analysis of variance between
// groups of errors (the dissertation's Figs. 6.1, 6.3, 6.7-6.9), with the F distribution from
// Boost.Math.
#pragma once

#include <string>
#include <vector>

namespace echoreg::core {

/// Tukey's box plot of one group: quartiles (linear interpolation between order statistics, as
/// numpy's default percentile), whiskers at the furthest values within 1.5 IQR of the box, and the
/// values beyond them.
struct BoxSummary {
  int count = 0;
  double mean = 0.0;
  double minimum = 0.0;
  double q1 = 0.0;
  double median = 0.0;
  double q3 = 0.0;
  double maximum = 0.0;
  double whiskerLow = 0.0;
  double whiskerHigh = 0.0;
  std::vector<double> outliers;
};

/// Throws std::invalid_argument when `values` is empty or holds a value that is not finite.
BoxSummary boxSummary(const std::vector<double>& values);

/// Percentile p (0..100) with linear interpolation between order statistics (numpy's default).
double percentile(std::vector<double> values, double p);

struct AnovaResult {
  double f = 0.0;       ///< between-group mean square over within-group mean square
  int dfBetween = 0;    ///< groups - 1
  int dfWithin = 0;     ///< values - groups
  double pValue = 1.0;  ///< P(F(dfBetween, dfWithin) > f)
  double sumSquaresBetween = 0.0;
  double sumSquaresWithin = 0.0;
};

/// One-way ANOVA of two or more groups. Throws std::invalid_argument with fewer than two groups,
/// an empty group, a value that is not finite, or no degree of freedom within groups. When every
/// value within each group is equal, f is infinite (p = 0) if the group means differ, else the
/// test is undefined and std::invalid_argument is thrown.
AnovaResult oneWayAnova(const std::vector<std::vector<double>>& groups);

}  // namespace echoreg::core
