#pragma once
// Runs jobs one after another, in submission order, on a thread of its own: work that a
// process must not do on its message thread (saving a map, sending a large reply).

#include <spdlog/spdlog.h>

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace liloc {

template <class Job>
class SerialWorker {
 public:
  // What the destructor does with jobs still queued.
  enum class OnStop { kFinishQueued, kDropQueued };

  // `run` is called on the worker thread; an exception it throws is logged, not fatal.
  SerialWorker(std::function<void(Job&)> run, OnStop on_stop)
      : run_(std::move(run)), on_stop_(on_stop), thread_([this] { loop(); }) {}
  ~SerialWorker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;

  void submit(Job job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      jobs_.push_back(std::move(job));
    }
    wake_.notify_all();
  }

 private:
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
  std::thread thread_;  // last: starts once the members above exist
};

}  // namespace liloc
