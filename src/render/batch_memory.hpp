// Whether a render batch's images fit in memory (renderer.cpp's render and renderReference hold a
// whole batch at once: 100 samples of 4095² pixels as floats are 27 GB). Internal: the renderer
// checks each request; tests give the machine's figures of their choosing.
#pragma once

#include <cstddef>
#include <string>

#include "duolod/core.hpp"

namespace duolod::render::internal {

struct MachineMemory {
  // Physical memory in bytes, or the control group's limit where that is lower; 0: unknown.
  double total = 0;
  bool group_limit = false;  // `total` is the control group's limit
  // What new allocations can take now without the kernel's out-of-memory killer stepping in:
  // /proc/meminfo's MemAvailable (free memory plus what the kernel can reclaim) plus SwapFree;
  // 0: unknown.
  double available = 0;
};
// This machine's figures, read now, within the memory limit of the process's control group (a
// container's, a CI job's, a systemd unit's) where there is one: there the kernel ends the process
// at the group's limit, whatever the machine has.
MachineMemory machineMemory();
// The same from the files under `root` ("" = the real ones): `root`/proc/meminfo,
// `root`/proc/self/cgroup and the groups' files under `root`/sys/fs/cgroup (cgroup v2's
// memory.max, memory.current and memory.stat; v1's memory.limit_in_bytes, memory.usage_in_bytes
// and memory.stat under the memory controller's mount). `physical` is the machine's memory.
MachineMemory readMachineMemory(const std::string& root, double physical);

// Refuses, with the figures, a batch of `count` images of tile² pixels of `bytes_per_pixel` ("as
// 8-bit RGBA"...) that needs more than the machine's memory, or more than is available now (the
// allocation would then succeed and the kernel end the process when the pages are touched).
core::Status checkBatchMemory(size_t count, int tile, size_t bytes_per_pixel, const char* as,
                              const MachineMemory& memory);
// The same against this machine's figures, read only for a batch above kSmallBatchBytes.
inline constexpr double kSmallBatchBytes = 256e6;
core::Status checkBatchMemory(size_t count, int tile, size_t bytes_per_pixel, const char* as);

}  // namespace duolod::render::internal
