// A fixed pool of render workers, each a thread with its own EGL context. Scheduling by
// deadline: interaction frames (due within a frame time) run before refinement steps (due
// whenever a worker is idle); within a class tasks run in the order they came. A session
// queues at most one task at a time, so the queue is fair.
#pragma once

#include <atomic>
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
  enum class Priority { kInteraction, kRefinement };
  // Starts `workers` threads and waits until each has its context; throws
  // renderer::RenderError when one cannot be made.
  explicit RenderPool(unsigned workers);
  ~RenderPool();
  void submit(Task task, Priority priority = Priority::kInteraction);
  const std::string& description() const { return description_; }
  size_t queued() const;
  // Whether an interaction task is waiting for a worker: a running refinement step gives its
  // worker up (RenderSettings::should_stop) when one is.
  bool interaction_waiting() const { return interaction_queued_.load(std::memory_order_relaxed) > 0; }

 private:
  void run(size_t index);
  std::vector<std::thread> threads_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, ready_;
  std::deque<Task> tasks_, refinement_tasks_;
  std::atomic<size_t> interaction_queued_{0};
  bool stopping_ = false;
  size_t started_ = 0;
  std::string error_, description_;
};

}  // namespace tetrascope::server
