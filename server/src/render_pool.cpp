#include "render_pool.h"

#include <malloc.h>

#include <cstdio>
#include <stdexcept>

#include "tetrascope/renderer/ray_caster.h"

namespace tetrascope::server {

RenderPool::RenderPool(unsigned workers, std::chrono::milliseconds idle_release, const std::string& backend) : idle_release_(idle_release), backend_(backend) {
  if (!renderer::known_backend(backend)) throw std::invalid_argument("backend: gl, cpu or auto");
  for (unsigned i = 0; i < std::max(1u, workers); ++i) threads_.emplace_back([this, i] { run(i); });
  std::unique_lock lock(mutex_);
  ready_.wait(lock, [&] { return started_ == threads_.size(); });
  if (!error_.empty()) {
    stopping_ = true;
    lock.unlock();
    wake_.notify_all();
    for (auto& t : threads_) t.join();
    throw renderer::RenderError(error_);
  }
}

RenderPool::~RenderPool() { shutdown(); }

void RenderPool::shutdown() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (auto& t : threads_)
    if (t.joinable()) t.join();
}

void RenderPool::submit(Task task, Priority priority) {
  Task dropped;  // destroyed outside the lock: it may hold the last reference to a session
  {
    std::lock_guard lock(mutex_);
    if (stopping_) {
      dropped = std::move(task);
      return;
    }
    if (priority == Priority::kInteraction) {
      tasks_.push_back(std::move(task));
      ++interaction_queued_;
    } else {
      refinement_tasks_.push_back(std::move(task));
    }
  }
  wake_.notify_one();
}

size_t RenderPool::queued() const {
  std::lock_guard lock(mutex_);
  return tasks_.size() + refinement_tasks_.size();
}

void RenderPool::run(size_t index) {
  Worker worker;
  try {
    worker.renderer = renderer::Renderer::create();
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    error_ = "render worker " + std::to_string(index) + ": " + e.what();
  }
  {
    std::lock_guard lock(mutex_);
    if (worker.renderer && description_.empty()) {
      description_ = worker.renderer->description();
      cpu_ = backend_ == "cpu" || (backend_ == "auto" && renderer::software_renderer(description_));
    }
    worker.cpu = cpu_;
    ++started_;
  }
  ready_.notify_all();
  if (worker.renderer) {
    try {
      warm_up(*worker.renderer);  // after the pool is up: the server does not wait for it
    } catch (const std::exception&) {
      // a first frame will report what fails
    }
  }
  bool holds_memory = false;  // drawn since the last release
  for (;;) {
    Task task;
    {
      std::unique_lock lock(mutex_);
      const auto has_work = [&] { return stopping_ || !tasks_.empty() || !refinement_tasks_.empty(); };
      if (holds_memory && worker.renderer && idle_release_.count() > 0 && !wake_.wait_for(lock, idle_release_, has_work)) {
        // idle for idle_release_: the scene, framebuffers and caches go (the next task uploads
        // again), then this thread's freed heap goes back to the system
        lock.unlock();
        worker.renderer->release_memory();
        worker.scene_generation = 0;
        holds_memory = false;
        ::malloc_trim(0);
        ++idle_releases_;
        continue;
      }
      wake_.wait(lock, has_work);
      if (stopping_) break;
      std::deque<Task>& from = tasks_.empty() ? refinement_tasks_ : tasks_;
      if (&from == &tasks_) --interaction_queued_;
      task = std::move(from.front());
      from.pop_front();
    }
    try {
      task(worker);  // tasks catch their own errors; one that did not is logged, the worker goes on
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tetrascope serve: a render task failed unexpectedly: %s\n", e.what());
    }
    holds_memory = true;
  }
  // The context stays up to exit (see run_render in apps/cmd_view.cpp): Mesa, unloaded by eglTerminate, leaves
  // allocations that leak checkers report against us.
  static std::mutex kept_mutex;
  static std::vector<renderer::Renderer*>* kept = new std::vector<renderer::Renderer*>();
  std::lock_guard lock(kept_mutex);
  if (worker.renderer) kept->push_back(worker.renderer.release());
}

}  // namespace tetrascope::server
