// Worker threads on a system that may refuse some of them.
#pragma once

#include <system_error>
#include <thread>
#include <vector>

namespace rt {

// Starts up to `count` threads running fn(k), k = 0, 1, ..., into `pool`, and returns how
// many started. The callers hand out their work through a shared counter, so where the
// system refuses a thread (a limit on threads or memory) those started do all of it;
// where it refuses the first, the error goes to the caller.
template <typename Fn>
int start_threads(std::vector<std::thread>& pool, int count, Fn&& fn) {
    pool.reserve(static_cast<size_t>(count));
    for (int k = 0; k < count; ++k) {
        try {
            pool.emplace_back(fn, k);
        } catch (const std::system_error&) {
            if (pool.empty()) throw;
            break;
        }
    }
    return static_cast<int>(pool.size());
}

}  // namespace rt
