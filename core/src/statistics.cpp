#include "echoreg/core/statistics.hpp"

#include <boost/math/distributions/fisher_f.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace echoreg::core {

double percentile(std::vector<double> values, double p) {
  if (values.empty())
    throw std::invalid_argument("percentile of no values");
  if (!(p >= 0.0 && p <= 100.0))
    throw std::invalid_argument("percentile outside 0..100");
  std::sort(values.begin(), values.end());
  const double position = p / 100.0 * static_cast<double>(values.size() - 1);
  const auto lower = static_cast<std::size_t>(std::floor(position));
  const std::size_t upper = std::min(lower + 1, values.size() - 1);
  const double f = position - static_cast<double>(lower);
  return values[lower] + f * (values[upper] - values[lower]);
}

BoxSummary boxSummary(const std::vector<double>& values) {
  if (values.empty())
    throw std::invalid_argument("box plot of an empty group");
  for (double v : values) {
    if (!std::isfinite(v))
      throw std::invalid_argument("box plot: a value is not finite");
  }
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  BoxSummary box;
  box.count = static_cast<int>(sorted.size());
  double sum = 0.0;
  for (double v : sorted)
    sum += v;
  box.mean = sum / static_cast<double>(sorted.size());
  box.minimum = sorted.front();
  box.maximum = sorted.back();
  box.q1 = percentile(sorted, 25.0);
  box.median = percentile(sorted, 50.0);
  box.q3 = percentile(sorted, 75.0);
  const double iqr = box.q3 - box.q1;
  const double lowFence = box.q1 - 1.5 * iqr;
  const double highFence = box.q3 + 1.5 * iqr;
  box.whiskerLow = box.q1;
  box.whiskerHigh = box.q3;
  for (double v : sorted) {
    if (v < lowFence || v > highFence) {
      box.outliers.push_back(v);
    } else {
      box.whiskerLow = std::min(box.whiskerLow, v);
      box.whiskerHigh = std::max(box.whiskerHigh, v);
    }
  }
  return box;
}

AnovaResult oneWayAnova(const std::vector<std::vector<double>>& groups) {
  if (groups.size() < 2)
    throw std::invalid_argument("ANOVA needs at least two groups");
  double total = 0.0;
  std::size_t n = 0;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].empty()) {
      throw std::invalid_argument("ANOVA: group " + std::to_string(g + 1) + " is empty");
    }
    for (double v : groups[g]) {
      if (!std::isfinite(v)) {
        throw std::invalid_argument("ANOVA: group " + std::to_string(g + 1) +
                                    " has a value that is not finite");
      }
      total += v;
      ++n;
    }
  }
  AnovaResult result;
  result.dfBetween = static_cast<int>(groups.size()) - 1;
  result.dfWithin = static_cast<int>(n) - static_cast<int>(groups.size());
  if (result.dfWithin < 1) {
    throw std::invalid_argument("ANOVA: no degree of freedom within the groups (one value each)");
  }
  const double grandMean = total / static_cast<double>(n);
  for (const auto& group : groups) {
    double sum = 0.0;
    for (double v : group)
      sum += v;
    const double mean = sum / static_cast<double>(group.size());
    result.sumSquaresBetween +=
        static_cast<double>(group.size()) * (mean - grandMean) * (mean - grandMean);
    for (double v : group)
      result.sumSquaresWithin += (v - mean) * (v - mean);
  }
  const double msBetween = result.sumSquaresBetween / result.dfBetween;
  const double msWithin = result.sumSquaresWithin / result.dfWithin;
  if (msWithin == 0.0) {
    if (msBetween == 0.0)
      throw std::invalid_argument("ANOVA: every value is equal; the test is undefined");
    result.f = std::numeric_limits<double>::infinity();
    result.pValue = 0.0;
    return result;
  }
  result.f = msBetween / msWithin;
  const boost::math::fisher_f distribution(result.dfBetween, result.dfWithin);
  result.pValue = boost::math::cdf(boost::math::complement(distribution, result.f));
  return result;
}

}  // namespace echoreg::core
