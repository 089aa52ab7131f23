// The thread pool of the C++ core: a fixed set of worker threads that run submitted tasks in
// submission order (FIFO). IECM batches (iecm/batch.cpp) and live streams (iecm/stream.cpp) and
// QZPM batches (qzpm/solve.cpp) run on it. Nothing polls: workers sleep on a condition variable
// until a task arrives, and callers wait on the futures of their tasks.
#pragma once
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

namespace psmat::numerics {

class ThreadPool {
 public:
  // n_threads workers (at least 1).
  explicit ThreadPool(int n_threads);
  // Runs the tasks still queued, then joins the workers.
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(threads_.size()); }

  // Queues task(worker), run by one worker thread; worker in [0, size()) names that thread, so a
  // task can use a per-thread workspace. The future becomes ready when the task has run and
  // rethrows its exception, if it threw one.
  std::future<void> submit(std::function<void(int worker)> task);

 private:
  void run(int worker);
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::packaged_task<void(int)>> tasks_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

// Number of hardware threads (at least 1).
int hardware_threads();

}  // namespace psmat::numerics
