// CommandLine implementation.
#include "common/command_line.h"

#include <cstdio>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace pf {

absl::StatusOr<CommandLine> CommandLine::Parse(const std::vector<std::string>& words,
                                               const std::set<std::string>& value_flags,
                                               const std::set<std::string>& bool_flags) {
  CommandLine cl;
  bool flags_done = false;
  for (size_t i = 0; i < words.size(); ++i) {
    const std::string& word = words[i];
    if (flags_done || word.size() < 3 || word.rfind("--", 0) != 0) {
      if (word == "--") {
        flags_done = true;
        continue;
      }
      cl.positional_.push_back(word);
      continue;
    }
    std::string name = word.substr(2);
    std::string value;
    bool has_inline_value = false;
    if (const size_t eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      has_inline_value = true;
    }
    if (bool_flags.count(name) > 0) {
      if (has_inline_value && value != "true" && value != "false") {
        return absl::InvalidArgumentError(absl::StrCat("--", name, " takes no value"));
      }
      cl.values_[name] = has_inline_value ? value : "true";
    } else if (value_flags.count(name) > 0) {
      if (!has_inline_value) {
        if (i + 1 >= words.size()) {
          return absl::InvalidArgumentError(absl::StrCat("--", name, " needs a value"));
        }
        value = words[++i];
      }
      cl.values_[name] = value;
    } else {
      return absl::InvalidArgumentError(absl::StrCat("unknown flag --", name));
    }
  }
  return cl;
}

absl::Status CommandLine::Require(const std::vector<std::string>& names,
                                  const std::string& usage) const {
  for (const std::string& name : names) {
    if (!Has(name))
      return absl::InvalidArgumentError(absl::StrCat("--", name, ": required\n", usage));
  }
  return absl::OkStatus();
}

absl::Status CommandLine::RequireBoth(const std::string& a, const std::string& b) const {
  if (Has(a) == Has(b)) return absl::OkStatus();
  const std::string& given = Has(a) ? a : b;
  const std::string& missing = Has(a) ? b : a;
  return absl::InvalidArgumentError(absl::StrCat("--", missing, ": required with --", given));
}

bool CommandLine::Has(const std::string& name) const {
  auto it = values_.find(name);
  return it != values_.end() && it->second != "false";
}

std::string CommandLine::Get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

absl::StatusOr<int64_t> CommandLine::GetInt(const std::string& name, int64_t fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  int64_t value;
  if (!absl::SimpleAtoi(it->second, &value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, ": '", it->second, "' is not an integer"));
  }
  return value;
}

absl::StatusOr<double> CommandLine::GetDouble(const std::string& name, double fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  double value;
  if (!absl::SimpleAtod(it->second, &value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, ": '", it->second, "' is not a number"));
  }
  return value;
}

std::vector<std::string> CommandLine::GetList(const std::string& name) const {
  if (values_.find(name) == values_.end()) return {};
  return absl::StrSplit(Get(name), ',');
}

int ExitStatusFor(const char* program, const absl::Status& status) {
  if (status.ok()) return 0;
  std::fprintf(stderr, "%s: %s\n", program, std::string(status.message()).c_str());
  return status.code() == absl::StatusCode::kInvalidArgument ? 2 : 1;
}

}  // namespace pf
