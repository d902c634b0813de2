// Caps on the long polls (WaitOperation) a server holds at once: each holds
// a thread and polls the store, so without a cap a few callers can take the
// server's threads and CPU from everyone else. One cap per caller, one for
// all callers together.
//
//   absl::StatusOr<LongPollLimiter::Slot> slot = limiter.Acquire(caller);
//   if (!slot.ok()) return ToGrpc(slot.status());   // RESOURCE_EXHAUSTED
//   ... wait; the slot is given back when it goes out of scope.
#ifndef POINTFORWARD_SERVER_LONG_POLLS_H_
#define POINTFORWARD_SERVER_LONG_POLLS_H_

#include <map>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"

namespace pf {

class LongPollLimiter {
 public:
  // 0 means no cap.
  LongPollLimiter(int max_total, int max_per_caller)
      : max_total_(max_total), max_per_caller_(max_per_caller) {}

  // One long poll in flight; gives its place back when destroyed.
  class Slot {
   public:
    Slot(Slot&& other) noexcept : limiter_(other.limiter_), caller_(std::move(other.caller_)) {
      other.limiter_ = nullptr;
    }
    Slot& operator=(Slot&&) = delete;
    ~Slot() {
      if (limiter_ != nullptr) limiter_->Release(caller_);
    }

   private:
    friend class LongPollLimiter;
    Slot(LongPollLimiter* limiter, std::string caller)
        : limiter_(limiter), caller_(std::move(caller)) {}
    LongPollLimiter* limiter_;
    std::string caller_;
  };

  // Takes a place for a long poll of `caller`, or RESOURCE_EXHAUSTED naming
  // the cap reached and its flag (--max-long-polls-per-caller,
  // --max-long-polls).
  absl::StatusOr<Slot> Acquire(const std::string& caller);

  // Long polls in flight, of `caller` and in all.
  int InFlight(const std::string& caller) const;
  int InFlight() const;

 private:
  void Release(const std::string& caller);

  const int max_total_;
  const int max_per_caller_;
  mutable std::mutex mu_;
  int total_ = 0;
  std::map<std::string, int> per_caller_;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_LONG_POLLS_H_
