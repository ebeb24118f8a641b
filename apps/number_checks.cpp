#include "number_checks.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <stdexcept>
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

std::array<double, 6> parseGridBounds(const std::string& text) {
  std::array<double, 6> v{};
  const char* at = text.c_str();
  for (std::size_t i = 0; i < v.size(); ++i) {
    char* end = nullptr;
    v[i] = std::strtod(at, &end);
    if (end == at || !std::isfinite(v[i]) || std::abs(v[i]) > 1e6) throw std::invalid_argument("bad number");
    at = end;
    if (i + 1 < v.size() && *at++ != ',') throw std::invalid_argument("too few numbers");
  }
  if (*at != '\0') throw std::invalid_argument("too many numbers");
  return v;
}

CLI::Validator gridBounds() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::array<double, 6> v{};
        try {
          v = parseGridBounds(text);
        } catch (const std::invalid_argument&) {
          return "'" + text + "' is not six numbers x0,y0,z0,x1,y1,z1 within [-1e6, 1e6]";
        }
        for (int a = 0; a < 3; ++a)
          if (!(v[std::size_t(a)] < v[std::size_t(a) + 3]))
            return std::string("the low corner must lie below the high one on every axis (") + "xyz"[a] + ")";
        return {};
      },
      "X0,Y0,Z0,X1,Y1,Z1");
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
