#pragma once
// Runs jobs on threads of its own: work that a process must not do on its message thread
// (saving a map, sending a large reply). With one thread, jobs run one after another in
// submission order; with more, queued jobs start in that order and run side by side.

#include <spdlog/spdlog.h>

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

namespace liloc {

template <class Job>
class WorkerPool {
 public:
  // What the destructor does with jobs still queued.
  enum class OnStop { kFinishQueued, kDropQueued };

  // `run` is called on a worker thread, from `threads` of them at once (so it must be
  // thread-safe when threads > 1); an exception it throws is logged, not fatal.
  WorkerPool(std::function<void(Job&)> run, OnStop on_stop, int threads = 1)
      : run_(std::move(run)), on_stop_(on_stop) {
    if (threads < 1) {
      throw std::invalid_argument("a worker pool needs at least one thread, got " +
                                  std::to_string(threads));
    }
    try {
      for (int i = 0; i < threads; ++i) {
        threads_.emplace_back([this] { loop(); });
      }
    } catch (...) {
      stop();  // the threads already started, or their destructors would terminate
      throw;
    }
  }
  ~WorkerPool() { stop(); }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void submit(Job job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      jobs_.push_back(std::move(job));
    }
    wake_.notify_one();
  }

 private:
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) {
      t.join();
    }
  }

  void loop() {
    while (true) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
        if (jobs_.empty() || (stopping_ && on_stop_ == OnStop::kDropQueued)) {
          return;
        }
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      try {
        run_(job);
      } catch (const std::exception& e) {
        spdlog::error("worker job failed: {}", e.what());
      }
    }
  }

  std::function<void(Job&)> run_;
  const OnStop on_stop_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> jobs_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;  // last: started once the members above exist
};

}  // namespace liloc
