#include "blobvk/blobtree/decimal.h"

#include <charconv>
#include <limits>
#include <system_error>

namespace blobvk::blobtree {

std::optional<Decimal> readDecimal(std::string_view text) {
  const char* first = text.data();
  const char* last = first + text.size();
  if (first != last && *first == '+') {
    ++first;
    if (first != last && (*first == '+' || *first == '-')) return std::nullopt;  // "+-1" is not a number
  }
  if (first == last) return std::nullopt;
  double v = 0.0;
  const auto [end, ec] = std::from_chars(first, last, v);
  if (end != last) return std::nullopt;
  if (ec == std::errc()) return Decimal{v, false};
  if (ec != std::errc::result_out_of_range) return std::nullopt;
  // Past double's range: long double (x86's has a wider exponent) gives the nearest double, 0, a
  // denormal or inf; past that too, the exponent's sign says which way.
  long double wide = 0.0L;
  const auto [wideEnd, wideEc] = std::from_chars(first, last, wide);
  if (wideEnd == last && wideEc == std::errc()) return Decimal{double(wide), true};
  const bool negative = *first == '-';
  const bool tiny = text.find("e-") != std::string_view::npos || text.find("E-") != std::string_view::npos;
  const double magnitude = tiny ? 0.0 : std::numeric_limits<double>::infinity();
  return Decimal{negative ? -magnitude : magnitude, true};
}

}  // namespace blobvk::blobtree
