#include "psmat/numerics/thread_pool.hpp"

#include <algorithm>
#include <utility>

namespace psmat::numerics {

int hardware_threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

ThreadPool::ThreadPool(int n_threads) {
  const int n = std::max(1, n_threads);
  threads_.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) threads_.emplace_back([this, k] { run(k); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

std::future<void> ThreadPool::submit(std::function<void(int)> task) {
  std::packaged_task<void(int)> job(std::move(task));
  std::future<void> done = job.get_future();
  {
    std::lock_guard<std::mutex> lock(mu_);
    tasks_.push_back(std::move(job));
  }
  cv_.notify_one();
  return done;
}

void ThreadPool::run(int worker) {
  for (;;) {
    std::packaged_task<void(int)> job;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
      if (tasks_.empty()) return;  // stopped and drained
      job = std::move(tasks_.front());
      tasks_.pop_front();
    }
    job(worker);  // an exception goes to the task's future
  }
}

}  // namespace psmat::numerics
