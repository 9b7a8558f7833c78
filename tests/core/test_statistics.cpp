#include "echoreg/core/statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

// Reference values from scipy.stats.f_oneway and numpy.percentile (/usr/bin/python3, scipy 1.10).
TEST(Statistics, OneWayAnovaMatchesScipy) {
  const auto r = echoreg::core::oneWayAnova({{0.24, 0.31, 0.18, 0.45, 0.29, 0.33},
                                             {0.52, 0.61, 0.47, 0.70, 0.39, 0.58, 0.66},
                                             {0.30, 0.28, 0.41, 0.36, 0.25}});
  EXPECT_NEAR(r.f, 15.864594843462237, 1e-10);
  EXPECT_NEAR(r.pValue, 0.0001989631127352939, 1e-12);
  EXPECT_EQ(r.dfBetween, 2);
  EXPECT_EQ(r.dfWithin, 15);
  const auto same = echoreg::core::oneWayAnova({{1, 2, 3}, {1.1, 2.1, 2.9}});
  EXPECT_NEAR(same.f, 0.00183823529411765, 1e-12);
  EXPECT_NEAR(same.pValue, 0.9678563239851905, 1e-10);
}

TEST(Statistics, BoxSummaryUsesNumpyQuartilesAndTukeyWhiskers) {
  const auto box = echoreg::core::boxSummary({0.52, 0.61, 0.47, 0.70, 0.39, 0.58, 0.66});
  EXPECT_NEAR(box.q1, 0.495, 1e-12);
  EXPECT_NEAR(box.median, 0.58, 1e-12);
  EXPECT_NEAR(box.q3, 0.635, 1e-12);
  EXPECT_TRUE(box.outliers.empty());
  EXPECT_DOUBLE_EQ(box.whiskerLow, 0.39);
  const auto withOutlier = echoreg::core::boxSummary({1, 2, 3, 4, 5, 40});
  ASSERT_EQ(withOutlier.outliers.size(), 1u);
  EXPECT_DOUBLE_EQ(withOutlier.outliers[0], 40);
  EXPECT_DOUBLE_EQ(withOutlier.whiskerHigh, 5);
}

TEST(Statistics, BadInputIsRefused) {
  EXPECT_THROW(echoreg::core::oneWayAnova({{1, 2}}), std::invalid_argument);
  EXPECT_THROW(echoreg::core::oneWayAnova({{1, 2}, {}}), std::invalid_argument);
  EXPECT_THROW(echoreg::core::oneWayAnova({{1}, {2}}), std::invalid_argument);
  EXPECT_THROW(echoreg::core::oneWayAnova({{1, NAN}, {2, 3}}), std::invalid_argument);
  EXPECT_THROW(echoreg::core::oneWayAnova({{1, 1}, {1, 1}}), std::invalid_argument);
  EXPECT_TRUE(std::isinf(echoreg::core::oneWayAnova({{1, 1}, {2, 2}}).f));
  EXPECT_THROW(echoreg::core::boxSummary({}), std::invalid_argument);
}

}  // namespace
