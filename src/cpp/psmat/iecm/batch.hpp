// Batches of frames on all cores (docs/spec.md §3 "(T,R,C) batches use all cores").
//
// A BatchJob owns a copy of its input and runs on its own thread pool (numerics/thread_pool.hpp),
// so the caller (Python) can release the GIL, wait with a timeout to drive a progress bar, and
// cancel. Two modes:
//  * streaming: frames are split into one contiguous chunk per thread; inside a chunk each
//    frame warm-starts from the previous solution and reuses its preconditioner;
//  * independent: every frame starts cold from g0 = G_exp (what a random-access job does).
#pragma once
#include <atomic>
#include <future>
#include <memory>
#include <vector>

#include "psmat/iecm/solve_options.hpp"
#include "psmat/numerics/thread_pool.hpp"
#include "psmat/types.hpp"

namespace psmat::iecm {

class Solver;

class BatchJob {
 public:
  // G: T x (R*C) row-major. initial (optional, same shape or empty): starting point of the
  // first frame of every chunk in streaming mode, or of every frame in independent mode.
  BatchJob(Shape shape, RowMatrixXd G, const SolveOptions& options, bool streaming,
           int n_threads, RowMatrixXd initial = RowMatrixXd());
  // Cancels and waits for the frames in flight.
  ~BatchJob();
  BatchJob(const BatchJob&) = delete;
  BatchJob& operator=(const BatchJob&) = delete;

  void start();
  // Blocks until all frames are done or `seconds` elapsed; true when done (and rethrows an
  // exception a worker met, e.g. std::bad_alloc). Negative: no limit.
  bool wait(double seconds);
  void cancel() { cancel_.store(true); }
  bool cancelled() const { return cancel_.load(); }
  Index completed() const { return completed_.load(); }
  Index frames() const { return G_.rows(); }

  const RowMatrixXd& g() const { return g_; }
  const std::vector<SolveReport>& reports() const { return reports_; }

 private:
  void solve_frame(Solver& solver, Index t, bool chunk_start);
  Shape shape_;
  RowMatrixXd G_, g_, initial_;
  SolveOptions opts_;
  bool streaming_;
  int n_threads_;
  std::vector<SolveReport> reports_;
  std::atomic<Index> completed_{0};
  std::atomic<Index> next_{0};
  std::atomic<bool> cancel_{false};
  std::unique_ptr<numerics::ThreadPool> pool_;
  std::vector<std::shared_future<void>> done_;  // one per task of the pool
};

// Number of hardware threads (at least 1).
using numerics::hardware_threads;

}  // namespace psmat::iecm
