// libFuzzer target: clip manifest parsing and validation (ParseClip, then
// ValidateClip without opening files). Any input must come back as a value or
// an absl::Status, never a crash, an exception or undefined behaviour.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/clip/clip_io.h"
#include "engine/clip/clip_validator.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string json(reinterpret_cast<const char*>(data), size);
  std::vector<pf::ClipProblem> problems;
  absl::StatusOr<pf::LoadedClip> loaded = pf::ParseClip(json, "/nonexistent/clip", &problems);
  if (!loaded.ok()) return 0;
  pf::ValidateOptions options;
  options.check_files = false;
  const pf::ClipReport report = pf::ValidateClip(*loaded, options);
  // Render every message too: the formatting code runs on hostile values.
  for (const pf::ClipProblem& problem : report.problems) (void)problem.ToString();
  (void)report.summary.ToString();
  (void)pf::ClipToJson(loaded->clip);
  return 0;
}
