// Progress bar and progress lines from pointforward.v1.OperationMetadata.
#include "client/remote/progress.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

// Returns the whole percent done, rounded down so 100% means done.
int Percent(const v1::OperationMetadata& metadata) {
  return static_cast<int>(std::floor(ProgressFraction(metadata) * 100.0 + 1e-9));
}

}  // namespace

double ProgressFraction(const v1::OperationMetadata& metadata) {
  double fraction = 0.0;
  if (metadata.fraction() > 0.0) {
    fraction = metadata.fraction();
  } else if (metadata.frames_total() > 0) {
    fraction = static_cast<double>(metadata.frames_done()) / metadata.frames_total();
  }
  return std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
}

std::string FormatProgressBar(const v1::OperationMetadata& metadata, int width) {
  const int filled =
      std::clamp(static_cast<int>(std::floor(ProgressFraction(metadata) * width + 1e-9)), 0, width);
  std::string text = absl::StrCat("[", std::string(filled, '#'), std::string(width - filled, '-'),
                                  "] ", absl::StrFormat("%3d%%", Percent(metadata)));
  if (metadata.frames_total() > 0) {
    absl::StrAppend(&text, "  ", metadata.frames_done(), "/", metadata.frames_total(), " frames");
  }
  if (!metadata.stage().empty()) absl::StrAppend(&text, "  ", metadata.stage());
  return text;
}

std::string FormatProgressLine(const std::string& name, const v1::OperationMetadata& metadata) {
  std::string text =
      absl::StrCat(name, ": ", metadata.state().empty() ? "PENDING" : metadata.state());
  if (metadata.frames_total() > 0) {
    absl::StrAppend(&text, " ", metadata.frames_done(), "/", metadata.frames_total(), " frames");
  }
  absl::StrAppend(&text, " (", Percent(metadata), "%)");
  if (!metadata.stage().empty()) absl::StrAppend(&text, " ", metadata.stage());
  return text;
}

void ProgressReporter::Update(const std::string& name, const v1::OperationMetadata& metadata) {
  const std::string text =
      interactive_ ? FormatProgressBar(metadata) : FormatProgressLine(name, metadata);
  if (text == last_) return;
  if (interactive_) {
    // Redraw in place; spaces wipe what a longer previous text left behind.
    const size_t pad = last_.size() > text.size() ? last_.size() - text.size() : 0;
    std::fprintf(out_, "\r%s%s", text.c_str(), std::string(pad, ' ').c_str());
  } else {
    std::fprintf(out_, "%s\n", text.c_str());
  }
  std::fflush(out_);
  last_ = text;
}

void ProgressReporter::Finish() {
  if (interactive_ && !last_.empty()) {
    std::fputc('\n', out_);
    std::fflush(out_);
  }
  last_.clear();
}

}  // namespace pf
