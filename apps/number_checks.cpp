#include "number_checks.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <string>

namespace blobvk::app {
namespace {

// `accepts` judges a parsed finite value; `what` names what is expected, in the message and help.
CLI::Validator finiteCheck(std::function<bool(double)> accepts, const std::string& what) {
  return CLI::Validator(
      [accepts, what](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        // Many of these options are floats: a value past float range (1e39) would become
        // infinite there, and one below it (1e-50) zero.
        const float f = float(v);
        if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || !std::isfinite(f) ||
            (v != 0 && f == 0) || !accepts(v))
          return "'" + text + "' is not " + what;
        return {};
      },
      what);
}

}  // namespace

CLI::Validator finiteRange(double lo, double hi) {
  // std::to_string prints 6 decimals; %g keeps "0.01" and "10000".
  char text[96];
  std::snprintf(text, sizeof text, "a number in [%g, %g]", lo, hi);
  return finiteCheck([lo, hi](double v) { return v >= lo && v <= hi; }, text);
}

CLI::Validator positiveFinite() {
  return finiteCheck([](double v) { return v > 0; }, "a finite number > 0");
}

CLI::Validator nonNegativeFinite() {
  return finiteCheck([](double v) { return v >= 0; }, "a finite number >= 0");
}

CLI::Validator nonEmptyText() {
  return CLI::Validator([](std::string& text) { return text.empty() ? std::string("an empty value means nothing here") : std::string(); },
                        "TEXT");
}

}  // namespace blobvk::app
