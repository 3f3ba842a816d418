// Configuration fields set by name from text (dqn_dovs_eval --dovs, --tracker): one table per configuration
// struct maps the names of its config file to its members.
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "dqn_dovs/common/parse.h"

namespace dqn_dovs {

/// One named member of Config: exactly one of the three pointers is set.
template <typename Config>
struct NamedField {
  const char* name;
  double Config::*real = nullptr;
  int Config::*integer = nullptr;
  bool Config::*flag = nullptr;
};

/// Sets the field called `name` from `value` ("true"/"false"/"1"/"0" for flags, a finite number, an integer for
/// integer fields). Returns an empty string, or a message beginning with `what` (e.g. "DOVS parameter") that names
/// the parameter and the reason; an unknown name gets `unknown_hint` appended.
template <typename Config>
std::string setNamedField(const std::vector<NamedField<Config>>& fields, Config& config, const std::string& what,
                          const std::string& name, const std::string& value, const std::string& unknown_hint) {
  for (const NamedField<Config>& f : fields) {
    if (name != f.name) continue;
    const std::string quoted = what + " '" + name + "' = '" + value + "'";
    if (f.flag != nullptr) {
      if (value == "true" || value == "1") {
        config.*f.flag = true;
      } else if (value == "false" || value == "0") {
        config.*f.flag = false;
      } else {
        return quoted + " is not true or false";
      }
      return {};
    }
    const std::optional<double> x = parseNumber(value);
    if (!x || !std::isfinite(*x)) return quoted + " is not a number";
    if (f.integer != nullptr) {
      if (*x != std::floor(*x) || std::abs(*x) > 1e6) return quoted + " is not an integer";
      config.*f.integer = static_cast<int>(*x);
    } else {
      config.*f.real = *x;
    }
    return {};
  }
  return "unknown " + what + " '" + name + "' " + unknown_hint;
}

/// The value of the field called `name` as setNamedField reads it back ("true"/"false", an integer, a number written to
/// round-trip), std::nullopt for an unknown name.
template <typename Config>
std::optional<std::string> namedFieldText(const std::vector<NamedField<Config>>& fields, const Config& config,
                                          const std::string& name) {
  for (const NamedField<Config>& f : fields) {
    if (name != f.name) continue;
    if (f.flag != nullptr) return std::string(config.*f.flag ? "true" : "false");
    if (f.integer != nullptr) return std::to_string(config.*f.integer);
    return formatRoundTrip(config.*f.real);
  }
  return std::nullopt;
}

/// The names of a field table, in its order.
template <typename Config>
std::vector<std::string> namedFieldNames(const std::vector<NamedField<Config>>& fields) {
  std::vector<std::string> names;
  names.reserve(fields.size());
  for (const NamedField<Config>& f : fields) names.emplace_back(f.name);
  return names;
}

}  // namespace dqn_dovs
