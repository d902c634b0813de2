// What a benchmark's JSON says of the machine and the process: the CPU
// model, the working threads, the peak resident memory.
#ifndef POINTFORWARD_COMMON_MACHINE_INFO_H_
#define POINTFORWARD_COMMON_MACHINE_INFO_H_

#include <cstdint>
#include <string>

namespace pf {

// /proc/cpuinfo's first "model name", or "unknown".
std::string CpuModel();

// The threads that work in a ParallelFor on DefaultThreadPool() (PF_THREADS).
int WorkingThreads();

// The process's peak resident set so far, in bytes (getrusage), or 0.
int64_t PeakRssBytes();

}  // namespace pf

#endif  // POINTFORWARD_COMMON_MACHINE_INFO_H_
