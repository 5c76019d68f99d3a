#include "piezo/model/parameters.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace piezo::model {
namespace {

TEST(Parameters, Table1DefaultsAreValid) {
  const Parameters p;
  EXPECT_TRUE(validate(p).empty());
  EXPECT_DOUBLE_EQ(p.drive.D(), 0.95 * 0.789);
  EXPECT_DOUBLE_EQ(p.motor.F_c(), 0.1 * 4.93e-3);
}

TEST(Parameters, EverySymbolIsFoundByName) {
  for (const char* name : {"V0", "f", "C_dr", "e_dr", "d_e", "M", "J", "C", "K", "r", "mu", "F_N",
                           "sigma0", "sigma1", "sigma2"}) {
    EXPECT_NE(find_parameter(name), nullptr) << name;
  }
  EXPECT_EQ(find_parameter("sigma3"), nullptr);
}

struct BadValue {
  const char* name;
  double value;
};

class ParameterValidation : public ::testing::TestWithParam<BadValue> {};

TEST_P(ParameterValidation, NamesTheParameterAndItsRange) {
  Parameters p;
  find_parameter(GetParam().name)->ref(p) = GetParam().value;
  const auto issues = validate(p);
  ASSERT_FALSE(issues.empty());
  EXPECT_EQ(issues.front().name, GetParam().name);
  EXPECT_NE(issues.front().message.find("allowed range"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Violations, ParameterValidation,
                         ::testing::Values(BadValue{"M", 0.0}, BadValue{"J", -1.0},
                                           BadValue{"K", 0.0}, BadValue{"r", -0.01},
                                           BadValue{"sigma0", 0.0}, BadValue{"f", 0.0},
                                           BadValue{"mu", std::numeric_limits<double>::quiet_NaN()},
                                           BadValue{"V0", std::numeric_limits<double>::infinity()},
                                           BadValue{"C", -1.0}, BadValue{"sigma1", -0.1},
                                           BadValue{"C_dr", 1.2}));

TEST(Parameters, RiseFractionMustLieStrictlyBetweenZeroAndOne) {
  Parameters p;
  p.drive.C_dr = 1.0;
  p.drive.e_dr = 1.0;
  const auto issues = validate(p);
  ASSERT_EQ(issues.size(), 1u);
  EXPECT_EQ(issues.front().name, "C_dr*e_dr");
  EXPECT_NE(issues.front().message.find("(0, 1)"), std::string::npos);
}

}  // namespace
}  // namespace piezo::model
