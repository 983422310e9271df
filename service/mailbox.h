#pragma once
/// @file mailbox.h
/// A one-slot "latest value" mailbox between the LCM thread (producer) and the scheduler
/// (consumer): a bounded blocking queue of capacity one whose Put replaces an unconsumed
/// item instead of blocking, so the consumer always gets the newest frame.

#include <condition_variable>
#include <mutex>
#include <optional>
#include <utility>

namespace g6d {

/// One-slot mailbox; every method is thread-safe.
template <typename T>
class LatestMailbox {
 public:
  /// What Put() did with the item.
  enum class PutResult {
    kStored,    ///< the slot was empty
    kReplaced,  ///< an unconsumed item was discarded for the new one (a drop)
    kStopped,   ///< the mailbox is stopped; the item was discarded
  };

  /// Stores `item`, replacing an unconsumed one. Never blocks on the consumer.
  PutResult Put(T item) {
    PutResult result;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopped_) return PutResult::kStopped;
      result = slot_ ? PutResult::kReplaced : PutResult::kStored;
      slot_ = std::move(item);
    }
    available_.notify_one();
    return result;
  }

  /// Blocks until an item is available or Stop() is called. Returns the item, or nothing
  /// once stopped (an item still in the slot then is abandoned; see Stop()).
  std::optional<T> Take() {
    std::unique_lock<std::mutex> lock(mutex_);
    available_.wait(lock, [this] { return stopped_ || slot_.has_value(); });
    if (stopped_) return std::nullopt;
    std::optional<T> item = std::move(slot_);
    slot_.reset();
    return item;
  }

  /// Refuses further items, wakes every waiter and discards an unconsumed item.
  /// Returns true when an item was discarded. Idempotent.
  bool Stop() {
    bool discarded;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
      discarded = slot_.has_value();
      slot_.reset();
    }
    available_.notify_all();
    return discarded;
  }

  /// True while an unconsumed item waits.
  bool Full() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return slot_.has_value();
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable available_;
  std::optional<T> slot_;
  bool stopped_ = false;
};

}  // namespace g6d
