#pragma once
// A small thread-safe FIFO between the SLAM's threads (tracking -> mapping keyframes, mapping ->
// tracking map updates). push() never blocks, so the camera thread never waits; the consumer
// either polls (tryPop) or sleeps until an item or close() arrives (waitPop). pushUrgent() lets an
// item overtake the ordinary ones (a lost camera's relocalisation request must not wait behind a
// backlog of keyframes). Shared by the two threads through a std::shared_ptr or a reference owned
// by their common parent.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>

namespace scale_drift_slam::common {

template <typename T>
class MessageQueue {
 public:
  /// Adds an item; ignored (returns false) after close().
  bool push(T item) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (closed_) return false;
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return true;
  }

  /// Adds an item ahead of every ordinary one, behind the urgent ones pushed before it (urgent
  /// items keep their order among themselves). Ignored (returns false) after close().
  bool pushUrgent(T item) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (closed_) return false;
      items_.insert(items_.begin() + static_cast<std::ptrdiff_t>(urgent_), std::move(item));
      ++urgent_;
    }
    ready_.notify_one();
    return true;
  }

  /// The oldest item (urgent ones first), or nothing when the queue is empty. Never blocks on an
  /// empty queue.
  std::optional<T> tryPop() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (items_.empty()) return std::nullopt;
    return popFront();
  }

  /// Waits for an item; returns nothing once the queue is closed and drained.
  std::optional<T> waitPop() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [this] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    return popFront();
  }

  /// No more pushes; waiting consumers drain what is left and then get nothing.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }

  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }

 private:
  T popFront() {  // with the lock held, on a non-empty queue
    T item = std::move(items_.front());
    items_.pop_front();
    if (urgent_ > 0) --urgent_;
    return item;
  }

  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<T> items_;
  std::size_t urgent_ = 0;  ///< The first urgent_ items were pushed urgent.
  bool closed_ = false;
};

}  // namespace scale_drift_slam::common
