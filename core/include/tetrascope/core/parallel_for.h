// The one parallel loop: work(item, worker) for items 0..count-1 on `workers` threads (the
// calling thread is worker 0). Items are handed out dynamically, so uneven items balance; a
// worker index lets callers keep per-thread scratch. The first exception stops the loop and
// is rethrown on the calling thread.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace tetrascope {

template <class Work>
void parallel_for(size_t count, unsigned workers, Work&& work) {
  workers = std::max(1u, std::min<unsigned>(workers, unsigned(std::max<size_t>(count, 1))));
  std::atomic<size_t> next{0};
  std::vector<std::exception_ptr> errors(workers);
  auto run = [&](unsigned w) {
    try {
      for (size_t i = next++; i < count; i = next++) work(i, w);
    } catch (...) {
      errors[w] = std::current_exception();
      next = count;
    }
  };
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < workers; ++w) pool.emplace_back(run, w);
  run(0);
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace tetrascope
