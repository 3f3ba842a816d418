// Reading numbers from text (parameters given by name, scenario files).
#pragma once

#include <cstdio>
#include <exception>
#include <optional>
#include <string>

namespace dqn_dovs {

/// The number `text` spells in full (std::stod's syntax: "0.5", "1e-3", "inf", "nan"); nullopt when it is empty,
/// not a number or followed by anything else. Callers that need a finite value check it themselves.
inline std::optional<double> parseNumber(const std::string& text) {
  size_t used = 0;
  double x = 0.0;
  try {
    x = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used == 0 || used != text.size()) return std::nullopt;
  return x;
}

/// `x` written with the fewest digits (up to 17) that parseNumber reads back as exactly `x` ("0.5", "4", "1.2").
inline std::string formatRoundTrip(double x) {
  char buf[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, x);
    if (const std::optional<double> back = parseNumber(buf); back && *back == x) return buf;
  }
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

}  // namespace dqn_dovs
