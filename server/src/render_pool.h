// A fixed pool of render workers, each a thread with its own EGL context. Tasks run in the
// order they came; a session queues at most one task at a time, so the queue is fair.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "frame_maker.h"

namespace tetrascope::server {

class RenderPool {
 public:
  using Task = std::function<void(Worker&)>;
  // Starts `workers` threads and waits until each has its context; throws
  // renderer::RenderError when one cannot be made.
  explicit RenderPool(unsigned workers);
  ~RenderPool();
  void submit(Task task);
  const std::string& description() const { return description_; }
  size_t queued() const;

 private:
  void run(size_t index);
  std::vector<std::thread> threads_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, ready_;
  std::deque<Task> tasks_;
  bool stopping_ = false;
  size_t started_ = 0;
  std::string error_, description_;
};

}  // namespace tetrascope::server
