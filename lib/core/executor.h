#pragma once
/// @file executor.h
/// Fan-out of independent work items. Library code never starts threads: the caller
/// passes an Executor (like Ceres' Context) and every stage runs its per-hypothesis work
/// through ParallelFor. Work items must write only to their own outputs, so the result
/// is the same for any number of threads.

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace g6d {

/// Runs independent work items.
class Executor {
 public:
  virtual ~Executor() = default;
  /// How many items may run at once (>= 1).
  virtual int NumThreads() const = 0;
  /// Calls fn(i) for every i in [0, n) and returns when all calls have returned.
  /// The calling thread takes part, so nested calls from inside fn cannot deadlock.
  /// Every item runs even when some throw; afterwards the exception of the lowest failing
  /// index is rethrown here, so any number of threads reports the same error.
  virtual void ParallelFor(int n, const std::function<void(int)>& fn) = 0;
};

/// Runs everything on the calling thread, in index order.
class InlineExecutor final : public Executor {
 public:
  int NumThreads() const override { return 1; }
  void ParallelFor(int n, const std::function<void(int)>& fn) override;
};

/// A fixed pool: `num_threads - 1` worker threads plus the thread that calls ParallelFor.
/// Owned by applications (tools, service, tests), never created inside lib/ algorithms.
/// A caller whose items are all claimed runs other queued work while it waits for them
/// (the helpers of a nested ParallelFor inside an item another thread runs), so that an
/// outer loop over a few items of unequal cost (a service frame: one detection, two
/// tracked instances) keeps every thread busy.
class ThreadPool final : public Executor {
 public:
  /// num_threads >= 1 is the total parallelism including the calling thread.
  explicit ThreadPool(int num_threads);
  ~ThreadPool() override;
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int NumThreads() const override { return static_cast<int>(workers_.size()) + 1; }
  void ParallelFor(int n, const std::function<void(int)>& fn) override;

 private:
  void WorkerLoop();
  friend struct ForState;

  std::mutex mutex_;
  std::condition_variable task_available_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace g6d
