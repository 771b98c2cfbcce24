// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>

#include "plumb/core/error.hpp"

namespace plumb {

int resolve_thread_count(int threads) {
  PLUMB_CHECK(threads >= 0, "threads = " << threads << " must be >= 0 (0 = every core)");
  if (threads > 0) return threads;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

void parallel_chunks(int threads, std::size_t chunks, const std::function<void(std::size_t)>& body) {
  const std::size_t workers = std::min<std::size_t>(static_cast<std::size_t>(resolve_thread_count(threads)), chunks);
  if (workers <= 1) {
    for (std::size_t c = 0; c < chunks; ++c) body(c);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors(chunks);
  auto work = [&] {
    for (std::size_t c = next.fetch_add(1); c < chunks; c = next.fetch_add(1)) {
      try {
        body(c);
      } catch (...) {
        errors[c] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  try {
    for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  } catch (...) {
    // The system refused a thread: the threads started and this one finish the chunks.
  }
  work();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace plumb
