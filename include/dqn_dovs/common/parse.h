// Reading numbers from text (parameters given by name, scenario files).
#pragma once

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

}  // namespace dqn_dovs
