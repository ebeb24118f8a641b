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

CLI::Validator cellSize() {
  return finiteCheck([](double v) { return v > 0 && v <= 1e6; }, "a cell size in (0, 1e6]");
}

CLI::Validator nonNegativeFinite() {
  return finiteCheck([](double v) { return v >= 0; }, "a finite number >= 0");
}

CLI::Validator mpuCells() {
  return CLI::Validator(
      [](std::string& text) {
        int v = 0;
        if (!CLI::detail::lexical_cast(text, v)) return "'" + text + "' is not a whole number";
        if (v == 0 || (v >= 2 && v <= 64)) return std::string();
        return "cells per MPU side must be 0 (the default) or 2 to 64, got " + text;
      },
      "0 or 2 to 64");
}

CLI::Validator nonEmptyText() {
  return CLI::Validator([](std::string& text) { return text.empty() ? std::string("an empty value means nothing here") : std::string(); },
                        "TEXT");
}

}  // namespace blobvk::app
