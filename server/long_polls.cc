// LongPollLimiter: see long_polls.h.
#include "server/long_polls.h"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace pf {

absl::StatusOr<LongPollLimiter::Slot> LongPollLimiter::Acquire(const std::string& caller) {
  std::lock_guard<std::mutex> lock(mu_);
  int& mine = per_caller_[caller];
  if (max_per_caller_ > 0 && mine >= max_per_caller_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "this caller already has ", max_per_caller_,
        " long polls in flight, the limit per caller (pf-server --max-long-polls-per-caller); "
        "poll with GetOperation instead"));
  }
  if (max_total_ > 0 && total_ >= max_total_) {
    if (mine == 0) per_caller_.erase(caller);
    return absl::ResourceExhaustedError(
        absl::StrCat("the server holds ", max_total_,
                     " long polls already, its limit (pf-server --max-long-polls); poll with "
                     "GetOperation instead"));
  }
  ++mine;
  ++total_;
  return Slot(this, caller);
}

void LongPollLimiter::Release(const std::string& caller) {
  std::lock_guard<std::mutex> lock(mu_);
  --total_;
  if (--per_caller_[caller] <= 0) per_caller_.erase(caller);
}

int LongPollLimiter::InFlight(const std::string& caller) const {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = per_caller_.find(caller);
  return it == per_caller_.end() ? 0 : it->second;
}

int LongPollLimiter::InFlight() const {
  std::lock_guard<std::mutex> lock(mu_);
  return total_;
}

}  // namespace pf
