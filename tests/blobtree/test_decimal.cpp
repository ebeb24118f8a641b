#include "blobvk/blobtree/decimal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace blobvk::blobtree {
namespace {

// The oracle: the value's definition (the nearest double; past double's range 0, a denormal or
// inf with the text's sign), not another parser.
TEST(ReadDecimal, TakesOneNumberAndItsNearestDouble) {
  EXPECT_EQ(readDecimal("2.5")->value, 2.5);
  EXPECT_EQ(readDecimal("+2.5")->value, 2.5);
  EXPECT_EQ(readDecimal("-1e3")->value, -1000.0);
  EXPECT_FALSE(readDecimal("-1e3")->beyondDouble);
  EXPECT_EQ(readDecimal("1e-310")->value, 1e-310);  // a denormal
  for (const char* tiny : {"1e-400", "-1e-400", "1e-5000", "-1e-5000"}) {
    const auto d = readDecimal(tiny);
    ASSERT_TRUE(d) << tiny;
    EXPECT_TRUE(d->beyondDouble) << tiny;
    EXPECT_EQ(d->value, 0.0) << tiny;
    EXPECT_EQ(std::signbit(d->value), tiny[0] == '-') << tiny;
  }
  for (const char* huge : {"1e400", "-1e400", "1e5000"}) {
    const auto d = readDecimal(huge);
    ASSERT_TRUE(d) << huge;
    EXPECT_TRUE(d->beyondDouble) << huge;
    EXPECT_EQ(d->value, huge[0] == '-' ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity());
  }
  // inf and nan are numbers, not numbers beyond range: the caller decides about them.
  EXPECT_TRUE(std::isinf(readDecimal("inf")->value));
  EXPECT_FALSE(readDecimal("inf")->beyondDouble);
  EXPECT_TRUE(std::isnan(readDecimal("nan")->value));
}

TEST(ReadDecimal, RefusesAnythingButExactlyOneNumber) {
  for (const char* bad : {"", "+", "-", "+-1", "++1", "--1", "1 ", " 1", "1,2", "0x1", "1e", "abc", "1.5f"})
    EXPECT_FALSE(readDecimal(bad)) << "'" << bad << "'";
}

}  // namespace
}  // namespace blobvk::blobtree
