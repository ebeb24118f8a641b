// One decimal number as blobvk reads it from text (legacy scene files, command-line lists): the
// same numbers on every platform and in every locale, and a number beyond double's range is
// still a number, as the JSON reader takes it.
#pragma once

#include <optional>
#include <string_view>

namespace blobvk::blobtree {

struct Decimal {
  double value = 0.0;         // beyond double's range: the nearest double, +-0 (or a denormal) or +-inf
  bool beyondDouble = false;  // the text's magnitude is past double's range (value is rounded)
};

// `text` whole: an optional '+' (no sign after it), then std::from_chars's general format
// ("1", "-2.5e3", "inf", "nan"). nullopt when it is not exactly one number.
std::optional<Decimal> readDecimal(std::string_view text);

}  // namespace blobvk::blobtree
