// What the benchmarks' JSON reports beside their timings (the CPU model,
// the working threads, the peak resident memory), and the median they
// report of them.
#ifndef POINTFORWARD_COMMON_MACHINE_INFO_H_
#define POINTFORWARD_COMMON_MACHINE_INFO_H_

#include <cstdint>
#include <string>
#include <vector>

namespace pf {

// /proc/cpuinfo's first "model name", or "unknown".
std::string CpuModel();

// The threads that work in a ParallelFor on DefaultThreadPool() (PF_THREADS).
int WorkingThreads();

// The process's peak resident set so far, in bytes (getrusage), or 0.
int64_t PeakRssBytes();

// The median of `values` (the mean of the middle two for an even count);
// `values` must not be empty.
double Median(std::vector<double> values);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_MACHINE_INFO_H_
