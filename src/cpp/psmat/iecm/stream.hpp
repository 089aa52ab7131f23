// Live crosstalk removal (thesis Fig. 2.10, docs/spec.md §3 "streaming"): frames are pushed as
// they arrive from the acquisition, a thread pool (numerics/thread_pool.hpp) solves them, one
// task per frame and one Solver per worker thread, and they come out in arrival order. Each frame warm-starts from the most recent solution available when its
// worker picks it up (the previous frame on one thread); the very first frame starts cold.
#pragma once
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "psmat/iecm/solve_options.hpp"
#include "psmat/numerics/thread_pool.hpp"
#include "psmat/types.hpp"

namespace psmat::iecm {

class Solver;

struct StreamResult {
  std::uint64_t seq = 0;
  Eigen::VectorXd g;
  SolveReport report;
  std::exception_ptr error;  // what the solve threw (pop() rethrows it), else null
};

class StreamSolver {
 public:
  // max_pending: frames queued or in flight before push() blocks (back-pressure).
  StreamSolver(Shape shape, const SolveOptions& options, int n_threads, std::size_t max_pending);
  ~StreamSolver();
  StreamSolver(const StreamSolver&) = delete;
  StreamSolver& operator=(const StreamSolver&) = delete;

  // Queues one frame (R*C equivalent conductances, copied) and returns its sequence number.
  // Waits while max_pending frames are pushed but not popped — up to timeout_s seconds
  // (negative: without limit), then returns kFull. Throws std::runtime_error once closed.
  static constexpr std::uint64_t kFull = ~std::uint64_t{0};
  std::uint64_t push(const ConstVecRef& G, double timeout_s = -1.0);
  // Next frame in order; waits up to timeout_s (negative: until available). False when no
  // frame became ready in time, or the stream is closed and drained. Rethrows what the solve of
  // that frame threw (e.g. std::bad_alloc).
  bool pop(StreamResult& out, double timeout_s);
  // Frames pushed but not yet popped.
  std::size_t pending() const;
  // Stops accepting frames; the pool still solves the queued ones.
  void close();
  const Shape& shape() const { return shape_; }

 private:
  void solve_next(int worker);  // one task of the pool: the oldest queued frame
  Shape shape_;
  SolveOptions opts_;
  std::size_t max_pending_;
  mutable std::mutex mu_;
  std::condition_variable cv_out_, cv_space_;
  std::deque<std::pair<std::uint64_t, Eigen::VectorXd>> queue_;
  std::map<std::uint64_t, StreamResult> done_;
  Eigen::VectorXd latest_g_;
  std::uint64_t latest_seq_ = 0;
  bool have_latest_ = false;
  std::uint64_t next_in_ = 0, next_out_ = 0;
  bool closed_ = false;
  std::vector<std::unique_ptr<Solver>> solvers_;  // one per worker: its preconditioner is kept
  std::unique_ptr<numerics::ThreadPool> pool_;
};

}  // namespace psmat::iecm
