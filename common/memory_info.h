// How much memory the process may still take, for stages that size their
// work to the machine (the colour fit's memory bound,
// engine/recon/colour_refinement.h).
#ifndef POINTFORWARD_COMMON_MEMORY_INFO_H_
#define POINTFORWARD_COMMON_MEMORY_INFO_H_

#include <cstdint>
#include <string_view>

namespace pf {

// The least of the system's available memory (MemAvailable in
// /proc/meminfo) and the room left under the limits of the process's cgroup
// and its ancestors (cgroup v2 memory.max less memory.current, or v1
// memory.limit_in_bytes less memory.usage_in_bytes; the usage less the
// inactive page cache, which the kernel reclaims first), in bytes; -1 where
// neither can be read.
// Memory this process has freed but keeps for reuse (memory_reuse.h) is not
// counted, so the figure errs low.
int64_t AvailableMemoryBytes();

// MemAvailable of a /proc/meminfo text in bytes; -1 when it has none.
int64_t MemAvailableFromMeminfo(std::string_view meminfo);

// The room under a cgroup limit: `limit` less `usage` (the two files'
// texts, decimal bytes) less `reclaimable` of that usage (memory.stat's
// inactive page cache), at least 0; -1 when there is no limit ("max", or
// v1's near-2^63 figure) or a text is not a number.
int64_t CgroupRoom(std::string_view limit, std::string_view usage, int64_t reclaimable = 0);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_MEMORY_INFO_H_
