#include "core/executor.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <memory>

#include "core/error.h"

namespace g6d {

namespace {
// Runs fn(0), ..., fn(n - 1) in order on this thread; all items run, then the exception of
// the lowest failing index (the first one here) is rethrown, as ThreadPool does.
void RunInOrder(int n, const std::function<void(int)>& fn) {
  std::exception_ptr error;
  for (int i = 0; i < n; ++i) {
    try {
      fn(i);
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}
}  // namespace

void InlineExecutor::ParallelFor(int n, const std::function<void(int)>& fn) { RunInOrder(n, fn); }

ThreadPool::ThreadPool(int num_threads) {
  if (num_threads < 1) G6D_THROW("ThreadPool: num_threads must be >= 1 (got " << num_threads << ")");
  workers_.reserve(static_cast<size_t>(num_threads - 1));
  for (int i = 0; i + 1 < num_threads; ++i) workers_.emplace_back([this] { WorkerLoop(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  task_available_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void ThreadPool::WorkerLoop() {
  for (;;) {
    std::function<void()> task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      task_available_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
      if (tasks_.empty()) return;  // stopping and drained
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    task();
  }
}

// Shared by the caller and the helper tasks of one ParallelFor call. Items are claimed
// through an atomic counter; helpers that start after every item is claimed do nothing,
// so `fn` (owned by the caller) is only touched while the caller is still waiting.
struct ForState {
  ThreadPool* pool = nullptr;
  int n = 0;
  const std::function<void(int)>* fn = nullptr;
  std::atomic<int> next{0};
  std::atomic<int> done{0};
  std::mutex mutex;          // guards error and error_index
  std::exception_ptr error;  // of the lowest failing index, whichever thread ran it
  int error_index = 0;

  void RunItems() {
    for (int i = next.fetch_add(1); i < n; i = next.fetch_add(1)) {
      std::exception_ptr item_error;
      try {
        (*fn)(i);
      } catch (...) {
        item_error = std::current_exception();
      }
      if (item_error) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!error || i < error_index) {
          error = item_error;
          error_index = i;
        }
      }
      if (done.fetch_add(1) + 1 == n) {
        // The caller waits on the pool's condition (it runs queued work meanwhile): wake
        // it under the pool's mutex, so that it cannot miss this between its check of
        // `done` and its wait.
        std::lock_guard<std::mutex> lock(pool->mutex_);
        pool->task_available_.notify_all();
      }
    }
  }
};

void ThreadPool::ParallelFor(int n, const std::function<void(int)>& fn) {
  if (n <= 0) return;
  if (workers_.empty() || n == 1) {
    RunInOrder(n, fn);
    return;
  }
  auto state = std::make_shared<ForState>();
  state->pool = this;
  state->n = n;
  state->fn = &fn;
  const int helpers = std::min(n - 1, static_cast<int>(workers_.size()));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (int h = 0; h < helpers; ++h) tasks_.emplace_back([state] { state->RunItems(); });
  }
  task_available_.notify_all();
  state->RunItems();
  // Every item is claimed; until the last one is done, run queued work (e.g. the helpers
  // of a ParallelFor nested in one of this call's items, on another thread).
  std::unique_lock<std::mutex> lock(mutex_);
  while (state->done.load() != n) {
    if (!tasks_.empty()) {
      std::function<void()> task = std::move(tasks_.front());
      tasks_.pop_front();
      lock.unlock();
      task();
      lock.lock();
      continue;
    }
    task_available_.wait(lock);
  }
  lock.unlock();
  std::exception_ptr error;
  {
    std::lock_guard<std::mutex> error_lock(state->mutex);
    error = state->error;
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace g6d
