// SqlValue conversions.
#include "server/store/sql_database.h"

#include <cstdlib>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace pf {

int64_t SqlValue::AsInt() const {
  if (const auto* i = std::get_if<int64_t>(&value_)) return *i;
  if (const auto* d = std::get_if<double>(&value_)) return static_cast<int64_t>(*d);
  if (const auto* s = std::get_if<std::string>(&value_)) {
    int64_t parsed = 0;
    if (absl::SimpleAtoi(*s, &parsed)) return parsed;
    double as_double = 0;
    if (absl::SimpleAtod(*s, &as_double)) return static_cast<int64_t>(as_double);
  }
  return 0;
}

double SqlValue::AsDouble() const {
  if (const auto* i = std::get_if<int64_t>(&value_)) return static_cast<double>(*i);
  if (const auto* d = std::get_if<double>(&value_)) return *d;
  if (const auto* s = std::get_if<std::string>(&value_)) {
    double parsed = 0;
    if (absl::SimpleAtod(*s, &parsed)) return parsed;
  }
  return 0;
}

std::string SqlValue::AsString() const {
  if (const auto* i = std::get_if<int64_t>(&value_)) return absl::StrCat(*i);
  if (const auto* d = std::get_if<double>(&value_)) return absl::StrCat(*d);
  if (const auto* s = std::get_if<std::string>(&value_)) return *s;
  return "";
}

}  // namespace pf
