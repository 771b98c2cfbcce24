// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The library's parallel layer: loops split into chunks fixed by the input size alone, so
///        a result never depends on the thread count.
///
/// A loop over n items is cut into chunks of `grain` items, [c*grain, min(n, (c+1)*grain)), the
/// same cut for any number of threads. Threads take chunks in any order; each chunk writes only its
/// own output, and the caller combines the outputs in chunk order. An algorithm built this way
/// gives bit-identical results on 1, 2 or 64 threads (floating-point sums included, since they are
/// summed in the same order), which the tests check for every algorithm that takes a thread count.
///
/// The helper threads of parallel_chunks() come from a pool kept for the life of the process,
/// started the first time a call asks for them (starting a thread costs some tens of
/// microseconds, and the per-frame loops make several calls a frame). The calling thread always
/// works on its own chunks too, so a call finishes even when every worker is busy, nested and
/// concurrent calls included; it returns once no thread touches its chunks any more. Each user
/// still picks a grain of at least a few hundred points: waking a worker is not free either.

#include <cstddef>
#include <functional>
#include <future>
#include <memory>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

namespace plumb {

/// @brief The number of threads a `threads` setting asks for: the value itself when >= 1, every
///        hardware thread of the machine for 0 (at least 1). Negative values throw plumb::Error.
int resolve_thread_count(int threads);

/// @brief Chunks of `grain` items (grain >= 1) that cover n items: ceil(n / grain).
constexpr std::size_t chunk_count(std::size_t n, std::size_t grain) { return grain == 0 ? 0 : (n + grain - 1) / grain; }

/// @brief Calls body(c) once for every chunk index c in [0, chunks), on up to `threads` threads
///        (the calling thread included; 0 = every hardware thread). With one thread, or one chunk,
///        everything runs on the calling thread in index order.
/// @throws whatever body threw: of several, the one of the lowest chunk index, so the error too does
///         not depend on the thread count (which chunks after a failing one still ran does).
void parallel_chunks(int threads, std::size_t chunks, const std::function<void(std::size_t)>& body);

/// @brief A loop over [0, n) whose items each append zero or more outputs: `f(begin, end, out)`
///        appends the outputs of items [begin, end) to `out`, in item order. The outputs of all
///        chunks are appended to `result` in chunk order, so `result` is exactly what one call
///        f(0, n, result) gives, whatever the thread count.
/// @param grain items per chunk (>= 1), a constant of the caller, never derived from `threads`
template <class T, class F>
void parallel_append(int threads, std::size_t n, std::size_t grain, std::vector<T>& result, F&& f) {
  const std::size_t chunks = chunk_count(n, grain);
  if (chunks <= 1 || threads == 1) {  // in place, chunk after chunk: the same calls as below
    for (std::size_t begin = 0; begin < n; begin += grain) f(begin, begin + grain < n ? begin + grain : n, result);
    return;
  }
  std::vector<std::vector<T>> parts(chunks);
  parallel_chunks(threads, chunks, [&](std::size_t c) {
    const std::size_t begin = c * grain;
    const std::size_t end = begin + grain < n ? begin + grain : n;
    f(begin, end, parts[c]);
  });
  std::size_t total = result.size();
  for (const auto& p : parts) total += p.size();
  result.reserve(total);
  for (auto& p : parts) {
    for (auto& v : p) result.push_back(std::move(v));
  }
}

/// @brief A loop over [0, n) whose items are independent and write only their own outputs:
///        `f(begin, end)` handles items [begin, end).
template <class F>
void parallel_for(int threads, std::size_t n, std::size_t grain, F&& f) {
  const std::size_t chunks = chunk_count(n, grain);
  if (chunks <= 1 || threads == 1) {  // chunk after chunk on this thread: the same calls as below
    for (std::size_t begin = 0; begin < n; begin += grain) f(begin, begin + grain < n ? begin + grain : n);
    return;
  }
  parallel_chunks(threads, chunks, [&](std::size_t c) {
    const std::size_t begin = c * grain;
    f(begin, begin + grain < n ? begin + grain : n);
  });
}

/// @brief `f()` started beside the caller: on a second thread when `threads` != 1 (0 = every core)
///        and the system gives one, else deferred, to run on the calling thread when get() is
///        called (never, if it is not).
///
/// Either way get() returns f()'s result or rethrows its exception at the same point of the
/// caller's code, so a caller written against the future does the same work with the same results
/// for any thread count, provided f() does not depend on what the caller does meanwhile. The
/// future of a started f() waits for it when destroyed.
template <class F>
auto start_beside(int threads, F f) -> std::future<std::invoke_result_t<F&>> {
  // Held once, so that what f carries is neither copied for the thread nor lost if none starts.
  auto call = [held = std::make_shared<F>(std::move(f))] { return (*held)(); };
  if (threads != 1) {
    try {
      return std::async(std::launch::async, call);
    } catch (const std::system_error&) {
      // no thread to be had: deferred to the caller's get()
    }
  }
  return std::async(std::launch::deferred, std::move(call));
}

}  // namespace plumb
