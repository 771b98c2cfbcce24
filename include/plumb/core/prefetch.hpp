// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Prefetch: a pipeline stage that makes items 0, 1, 2, ... on its own thread, a few ahead of
///        the consumer (reading and deskewing the next frames while the estimator works on this one).

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

namespace plumb {

/// @brief A pipeline stage: items 0, 1, 2, ... made by `make(i)` in index order on a thread of their
///        own, up to `depth` items ahead of the one the consumer asks for next, while the consumer
///        works on the item before.
///
/// `make` must depend on i and on the items made before it alone, never on what the consumer did
/// with earlier items: the items, and so everything computed from them, are then the same for any
/// thread count and any depth. make() is called in index order and never twice at once, so a stage
/// may keep state from one item to the next (a scan matcher's last scan). The stage's thread starts
/// on item 0 when the Prefetch is made; it waits, without spinning, whenever `depth` items are made
/// and not yet taken, so at most depth + 1 items exist at once (the one the consumer holds
/// included). A depth above 1 lets stages of uneven, varying cost run side by side without waiting
/// for each other frame by frame.
///
/// With threads == 1 (or when the system refuses a thread) each item is made on the calling thread
/// when asked for. An exception of make(i) is rethrown by get(i), where the serial loop would have
/// met it, and nothing after item i is made. Asking out of order (get(j) after get(i), j != i + 1)
/// drops the items made ahead and goes on from j.
template <class T>
class Prefetch {
 public:
  /// @param threads the caller's thread setting (1 = no thread of its own; 0 = every core, as >= 2)
  /// @param n number of items; get() is called with i = 0, 1, ... (it may stop early)
  /// @param depth items made ahead of the consumer (>= 1; 0 is taken as 1)
  Prefetch(int threads, std::size_t n, std::function<T(std::size_t)> make, std::size_t depth = 1)
      : n_(n), depth_(depth == 0 ? 1 : depth), make_(std::move(make)) {
    if (threads == 1 || n == 0) return;
    try {
      worker_ = std::thread([this] { produce(); });
    } catch (const std::system_error&) {
      // no thread to be had: every item is made on the caller's get()
    }
  }
  Prefetch(const Prefetch&) = delete;
  Prefetch& operator=(const Prefetch&) = delete;
  /// Waits for the item being made, if any; makes nothing more.
  ~Prefetch() {
    if (!worker_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_worker_.notify_one();
    worker_.join();
  }

  /// @brief Item i (< n): made ahead (or made now, on one thread); rethrows make(i)'s exception.
  /// @throws std::out_of_range for i >= n
  T get(std::size_t i) {
    if (i >= n_) throw std::out_of_range("Prefetch: item " + std::to_string(i) + " asked of " + std::to_string(n_));
    if (!worker_.joinable()) return make_(i);
    std::unique_lock<std::mutex> lock(mutex_);
    if (i != next_taken_) {  // out of order: what was made ahead is dropped
      ready_.clear();
      next_made_ = i;
      failed_ = false;
      ++generation_;
    }
    next_taken_ = i;
    wake_worker_.notify_one();
    wake_consumer_.wait(lock, [this] { return !ready_.empty(); });
    Made made = std::move(ready_.front());
    ready_.pop_front();
    next_taken_ = i + 1;
    lock.unlock();
    wake_worker_.notify_one();
    if (made.error) std::rethrow_exception(made.error);
    return std::move(*made.item);
  }

 private:
  struct Made {
    std::optional<T> item;
    std::exception_ptr error;
  };

  void produce() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_worker_.wait(lock, [this] {
        return stop_ || (!failed_ && next_made_ < n_ && next_made_ < next_taken_ + depth_);
      });
      if (stop_) return;
      const std::size_t i = next_made_++;
      const unsigned long generation = generation_;
      lock.unlock();
      Made made;
      try {
        made.item.emplace(make_(i));
      } catch (...) {
        made.error = std::current_exception();
      }
      lock.lock();
      if (generation != generation_) continue;  // dropped by an out-of-order get() meanwhile
      failed_ = made.error != nullptr;
      ready_.push_back(std::move(made));
      wake_consumer_.notify_one();
    }
  }

  std::size_t n_;
  std::size_t depth_;
  std::function<T(std::size_t)> make_;
  std::mutex mutex_;
  std::condition_variable wake_worker_;    ///< an item was taken, the order changed, or stop
  std::condition_variable wake_consumer_;  ///< an item (or its error) is ready
  std::deque<Made> ready_;                 ///< made, not taken, in index order from next_taken_
  std::size_t next_made_ = 0;              ///< the index the worker makes next
  std::size_t next_taken_ = 0;             ///< the index the consumer asks for next
  unsigned long generation_ = 0;           ///< counts out-of-order gets: older items are dropped
  bool failed_ = false;                    ///< the last item made threw: nothing after it is made
  bool stop_ = false;
  std::thread worker_;  ///< last: it starts when every member it reads is made
};

}  // namespace plumb
