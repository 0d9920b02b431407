// A fixed pool of render workers, each a thread with its own EGL context. Scheduling by
// deadline: interaction frames (due within a frame time) run before refinement steps (due
// whenever a worker is idle); within a class tasks run in the order they came. A session
// queues at most one task at a time, so the queue is fair.
#pragma once

#include <atomic>
#include <chrono>
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
  // renderer::RenderError when one cannot be made. A worker that has drawn and then gets no
  // task for `idle_release` releases its renderer's memory (Renderer::release_memory).
  // `backend`: "gl", "cpu" (the CPU ray caster draws what it can, the GL renderer the rest)
  // or "auto" (cpu where the GL renderer is software).
  explicit RenderPool(unsigned workers, std::chrono::milliseconds idle_release = std::chrono::seconds(5), const std::string& backend = "gl");
  ~RenderPool();
  // Stops the workers after their current task and joins them; tasks submitted from then on
  // (a worker's task pacing the session's next frame, say) are dropped. The pool must stay
  // reachable until this returns: the server calls it before letting go of the pool.
  void shutdown();
  void submit(Task task, Priority priority = Priority::kInteraction);
  const std::string& description() const { return description_; }
  bool cpu() const { return cpu_; }  // the workers draw volumes with the CPU ray caster
  size_t queued() const;
  // Workers that released their memory after going idle, in all (tests, /metrics).
  uint64_t idle_releases() const { return idle_releases_.load(std::memory_order_relaxed); }
  // Whether an interaction task is waiting for a worker: a running refinement step gives its
  // worker up (RenderSettings::should_stop) when one is.
  bool interaction_waiting() const { return interaction_queued_.load(std::memory_order_relaxed) > 0; }
  // Interaction frames waiting for a worker, and the workers.
  size_t interaction_queued() const { return interaction_queued_.load(std::memory_order_relaxed); }
  size_t workers() const { return threads_.size(); }

 private:
  void run(size_t index);
  std::vector<std::thread> threads_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, ready_;
  std::deque<Task> tasks_, refinement_tasks_;
  std::atomic<size_t> interaction_queued_{0};
  std::atomic<uint64_t> idle_releases_{0};
  std::chrono::milliseconds idle_release_;
  bool stopping_ = false;
  size_t started_ = 0;
  std::string error_, description_;
  std::string backend_;
  bool cpu_ = false;
};

}  // namespace tetrascope::server
