// Seconds on the steady clock, for stage timings and progress lines.
#ifndef POINTFORWARD_COMMON_ELAPSED_H_
#define POINTFORWARD_COMMON_ELAPSED_H_

#include <chrono>

namespace pf {

// Seconds since `start` (a steady_clock::now() taken earlier).
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace pf

#endif  // POINTFORWARD_COMMON_ELAPSED_H_
