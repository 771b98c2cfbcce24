// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

#include "plumb/core/error.hpp"

namespace plumb {

int resolve_thread_count(int threads) {
  PLUMB_CHECK(threads >= 0, "threads = " << threads << " must be >= 0 (0 = every core)");
  if (threads > 0) return threads;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

namespace {

// One parallel_chunks() call: its chunks are claimed one at a time by the caller and by the
// workers that join it.
struct Job {
  const std::function<void(std::size_t)>* body = nullptr;
  std::size_t chunks = 0;
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors;  ///< per chunk
  int active = 0;                          ///< workers inside work(); guarded by the pool's mutex

  void work() {
    for (std::size_t c = next.fetch_add(1); c < chunks; c = next.fetch_add(1)) {
      try {
        (*body)(c);
      } catch (...) {
        errors[c] = std::current_exception();
      }
    }
  }
};

// Worker threads kept for the life of the process, started the first time a call asks for them
// (and more when a later call asks for more). Starting a thread costs tens of microseconds, and
// the per-frame loops make several parallel calls per frame. A call queues one entry per helper
// it wants, works on its own chunks too, then withdraws the entries no worker took and waits for
// the workers that did: so it never waits on a busy pool (nested or concurrent calls included),
// and it returns only when nothing touches its job any more.
class WorkerPool {
 public:
  static WorkerPool& instance() {
    static WorkerPool pool;
    return pool;
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

  void run(Job& job, std::size_t helpers) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (threads_.size() < helpers) {
        try {
          threads_.emplace_back([this] { serve(); });
        } catch (const std::system_error&) {
          break;  // the system refused a thread: the ones there (or the caller alone) do the work
        }
      }
      for (std::size_t h = 0; h < helpers; ++h) queue_.push_back(&job);
    }
    if (helpers == 1) {
      wake_.notify_one();
    } else {
      wake_.notify_all();
    }
    job.work();
    std::unique_lock<std::mutex> lock(mutex_);
    queue_.erase(std::remove(queue_.begin(), queue_.end(), &job), queue_.end());
    left_.wait(lock, [&job] { return job.active == 0; });
  }

 private:
  WorkerPool() = default;

  void serve() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping
      Job* job = queue_.front();
      queue_.pop_front();
      ++job->active;
      lock.unlock();
      job->work();
      lock.lock();
      if (--job->active == 0) left_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;  ///< workers: an entry was queued, or the pool stops
  std::condition_variable left_;  ///< callers: a worker left a job
  std::deque<Job*> queue_;
  std::vector<std::thread> threads_;
  bool stop_ = false;
};

}  // namespace

void parallel_chunks(int threads, std::size_t chunks, const std::function<void(std::size_t)>& body) {
  const std::size_t workers = std::min<std::size_t>(static_cast<std::size_t>(resolve_thread_count(threads)), chunks);
  if (workers <= 1) {
    for (std::size_t c = 0; c < chunks; ++c) body(c);
    return;
  }
  Job job;
  job.body = &body;
  job.chunks = chunks;
  job.errors.resize(chunks);
  WorkerPool::instance().run(job, workers - 1);
  for (const std::exception_ptr& e : job.errors) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace plumb
