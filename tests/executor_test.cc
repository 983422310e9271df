#include "core/executor.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"

namespace g6d {
namespace {

// Executors under test: inline, and pools of several sizes.
std::vector<std::unique_ptr<Executor>> MakeExecutors() {
  std::vector<std::unique_ptr<Executor>> executors;
  executors.push_back(std::make_unique<InlineExecutor>());
  for (int threads : {1, 2, 4}) executors.push_back(std::make_unique<ThreadPool>(threads));
  return executors;
}

// A deterministic per-index computation with enough work to interleave threads.
double WorkItem(int index) {
  std::mt19937_64 engine(1000 + index);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double sum = 0.0;
  for (int k = 0; k < 2000; ++k) sum += uniform(engine) * (index + 1);
  return sum;
}

TEST(ThreadPool, NumThreadsCountsTheCaller) {
  EXPECT_EQ(InlineExecutor().NumThreads(), 1);
  EXPECT_EQ(ThreadPool(1).NumThreads(), 1);
  EXPECT_EQ(ThreadPool(3).NumThreads(), 3);
}

TEST(ThreadPool, RejectsFewerThanOneThread) {
  EXPECT_THROW(ThreadPool(0), Error);
  EXPECT_THROW(ThreadPool(-2), Error);
}

TEST(ParallelFor, RunsEveryIndexExactlyOnce) {
  for (const auto& executor : MakeExecutors()) {
    for (int n : {0, 1, 2, 3, 7, 64, 1000}) {
      std::vector<std::atomic<int>> calls(static_cast<size_t>(n));
      for (auto& count : calls) count = 0;
      executor->ParallelFor(n, [&](int i) { calls[static_cast<size_t>(i)].fetch_add(1); });
      for (int i = 0; i < n; ++i) {
        EXPECT_EQ(calls[static_cast<size_t>(i)].load(), 1)
            << "index " << i << " of " << n << ", " << executor->NumThreads() << " threads";
      }
    }
  }
}

TEST(ParallelFor, NegativeCountRunsNothing) {
  for (const auto& executor : MakeExecutors()) {
    std::atomic<int> calls{0};
    executor->ParallelFor(-5, [&](int) { ++calls; });
    EXPECT_EQ(calls.load(), 0);
  }
}

TEST(InlineExecutor, RunsInIndexOrderOnCallingThread) {
  InlineExecutor executor;
  std::vector<int> order;
  const std::thread::id caller = std::this_thread::get_id();
  executor.ParallelFor(5, [&](int i) {
    order.push_back(i);
    EXPECT_EQ(std::this_thread::get_id(), caller);
  });
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4}));
}

TEST(ParallelFor, NestedCallsDoNotDeadlock) {
  for (const auto& executor : MakeExecutors()) {
    // Three levels, more outer items than threads, so every worker blocks in a nested call.
    std::atomic<int> leaves{0};
    executor->ParallelFor(8, [&](int) {
      executor->ParallelFor(
          6, [&](int) { executor->ParallelFor(5, [&](int) { leaves.fetch_add(1); }); });
    });
    EXPECT_EQ(leaves.load(), 8 * 6 * 5) << executor->NumThreads() << " threads";
  }
}

TEST(ParallelFor, ExceptionPropagatesAfterAllItems) {
  for (const auto& executor : MakeExecutors()) {
    std::vector<std::atomic<int>> calls(50);
    for (auto& count : calls) count = 0;
    try {
      executor->ParallelFor(50, [&](int i) {
        calls[static_cast<size_t>(i)].fetch_add(1);
        if (i == 13 || i == 31) throw std::runtime_error("item " + std::to_string(i));
      });
      ADD_FAILURE() << "no exception, " << executor->NumThreads() << " threads";
    } catch (const std::runtime_error& error) {
      // The lowest failing index, whatever the thread count.
      EXPECT_STREQ(error.what(), "item 13") << executor->NumThreads() << " threads";
    }
    for (int i = 0; i < 50; ++i)
      EXPECT_EQ(calls[static_cast<size_t>(i)].load(), 1) << "index " << i;
    // Still usable afterwards.
    std::atomic<int> after{0};
    executor->ParallelFor(20, [&](int) { ++after; });
    EXPECT_EQ(after.load(), 20);
  }
}

TEST(ParallelFor, NestedExceptionReachesOuterCaller) {
  for (const auto& executor : MakeExecutors()) {
    EXPECT_THROW(executor->ParallelFor(4,
                                       [&](int outer) {
                                         executor->ParallelFor(4, [&](int inner) {
                                           if (outer == 2 && inner == 1) throw Error("nested");
                                         });
                                       }),
                 Error);
  }
}

TEST(ParallelFor, SameResultsForOneAndFourThreads) {
  const int n = 300;
  std::vector<double> reference(n);
  InlineExecutor().ParallelFor(n, [&](int i) { reference[static_cast<size_t>(i)] = WorkItem(i); });
  for (int threads : {1, 4}) {
    ThreadPool pool(threads);
    std::vector<double> results(n, -1.0);
    pool.ParallelFor(n, [&](int i) { results[static_cast<size_t>(i)] = WorkItem(i); });
    EXPECT_EQ(results, reference) << threads << " threads";
  }
}

TEST(ThreadPool, ManyShortCallsInARow) {
  ThreadPool pool(4);
  long long total = 0;
  for (int call = 0; call < 500; ++call) {
    std::vector<int> values(static_cast<size_t>(call % 9 + 1), 0);
    pool.ParallelFor(static_cast<int>(values.size()),
                     [&](int i) { values[static_cast<size_t>(i)] = i + 1; });
    for (int value : values) total += value;
  }
  long long expected = 0;
  for (int call = 0; call < 500; ++call) {
    const int n = call % 9 + 1;
    expected += n * (n + 1) / 2;
  }
  EXPECT_EQ(total, expected);
}

TEST(ThreadPool, CallersFromSeveralThreadsShareThePool) {
  ThreadPool pool(3);
  std::vector<std::atomic<int>> sums(4);
  for (auto& sum : sums) sum = 0;
  std::vector<std::thread> callers;
  for (int c = 0; c < 4; ++c) {
    callers.emplace_back([&, c] {
      for (int repeat = 0; repeat < 50; ++repeat) {
        pool.ParallelFor(10, [&](int i) { sums[static_cast<size_t>(c)].fetch_add(i); });
      }
    });
  }
  for (std::thread& caller : callers) caller.join();
  for (const auto& sum : sums) EXPECT_EQ(sum.load(), 50 * 45);
}

// An outer loop over a quick item and one that runs a nested loop: whichever thread
// finishes the quick item (the caller or the worker) must take a nested item, so the two
// nested items run at the same time. Each waits (up to 10 s, not a timing assertion) for
// the other to start.
TEST(ThreadPool, AWaitingCallerRunsNestedWorkOfAnotherThread) {
  ThreadPool pool(2);
  for (int round = 0; round < 20; ++round) {
    std::mutex mutex;
    std::condition_variable started;
    int running = 0;
    std::atomic<int> met{0};
    pool.ParallelFor(2, [&](int outer) {
      if (outer == 0) return;
      pool.ParallelFor(2, [&](int) {
        std::unique_lock<std::mutex> lock(mutex);
        ++running;
        started.notify_all();
        if (started.wait_for(lock, std::chrono::seconds(10), [&] { return running == 2; })) ++met;
      });
    });
    EXPECT_EQ(met.load(), 2) << "round " << round << ": the nested items did not run side by side";
  }
}

TEST(ThreadPool, DestroysCleanlyRightAfterWork) {
  for (int round = 0; round < 50; ++round) {
    ThreadPool pool(4);
    std::atomic<int> calls{0};
    pool.ParallelFor(3, [&](int) { ++calls; });
    EXPECT_EQ(calls.load(), 3);
  }
}

}  // namespace
}  // namespace g6d
