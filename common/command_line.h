// A small command-line parser for `pf` subcommands and the daemons.
//
//   ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(args, {"out", "seed"}, {"wait"}));
//   ASSIGN_OR_RETURN(int seed, cl.GetInt("seed", 1));
//
// Accepts "--name value", "--name=value", boolean "--name", and positional
// words; "--" ends the flags. Unknown flags are INVALID_ARGUMENT naming them.
#ifndef POINTFORWARD_COMMON_COMMAND_LINE_H_
#define POINTFORWARD_COMMON_COMMAND_LINE_H_

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace pf {

class CommandLine {
 public:
  // Parses `words` (without the program and subcommand names). `value_flags`
  // take a value; `bool_flags` take none.
  static absl::StatusOr<CommandLine> Parse(const std::vector<std::string>& words,
                                           const std::set<std::string>& value_flags,
                                           const std::set<std::string>& bool_flags = {});

  const std::vector<std::string>& positional() const { return positional_; }
  // Returns true if flag `name` was given.
  bool Has(const std::string& name) const;
  // Returns the value of `name`, or `fallback` when absent.
  std::string Get(const std::string& name, const std::string& fallback = "") const;
  // Returns the value of `name` as an integer / double; INVALID_ARGUMENT naming
  // the flag if it is not one.
  absl::StatusOr<int64_t> GetInt(const std::string& name, int64_t fallback) const;
  absl::StatusOr<double> GetDouble(const std::string& name, double fallback) const;
  // Returns the value split at commas: nothing when the flag is absent; an
  // empty item ("a,,b", or an empty value) is kept as "" for the caller to
  // reject with its own message.
  std::vector<std::string> GetList(const std::string& name) const;
  // Returns OK when every flag of `names` was given, else INVALID_ARGUMENT
  // "--NAME: required" for the first missing one, then `usage` on its own line.
  absl::Status Require(const std::vector<std::string>& names, const std::string& usage) const;
  // Returns OK when flags `a` and `b` are both given or both absent, else
  // INVALID_ARGUMENT "--B: required with --A" (or the other way round).
  absl::Status RequireBoth(const std::string& a, const std::string& b) const;

 private:
  std::vector<std::string> positional_;
  std::map<std::string, std::string> values_;
};

// Returns main()'s exit status for a program that ended with `status`: 0
// when it is OK; else prints "PROGRAM: message" to stderr and returns 2 for
// INVALID_ARGUMENT (a bad flag), 1 for any other error. The benchmark and
// check programs (pf_fusion_bench, pf_store_bench, ...) end with it.
int ExitStatusFor(const char* program, const absl::Status& status);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_COMMAND_LINE_H_
