#include "psmat/iecm/batch.hpp"

#include <algorithm>
#include <chrono>

#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

BatchJob::BatchJob(Shape shape, RowMatrixXd G, const SolveOptions& options, bool streaming,
                   int n_threads, RowMatrixXd initial)
    : shape_(shape),
      G_(std::move(G)),
      g_(G_.rows(), G_.cols()),
      initial_(std::move(initial)),
      opts_(options),
      streaming_(streaming),
      n_threads_(std::max(1, n_threads)),
      reports_(static_cast<size_t>(G_.rows())) {}

BatchJob::~BatchJob() {
  cancel();
  pool_.reset();  // the tasks see the flag after their current frame; joined before the data goes
}

void BatchJob::solve_frame(Solver& solver, Index t, bool chunk_start) {
  bool warm = false;
  if (initial_.rows() == G_.rows() && (!streaming_ || chunk_start)) {
    g_.row(t) = initial_.row(t);
    warm = true;
  } else if (streaming_ && !chunk_start) {
    g_.row(t) = g_.row(t - 1);  // warm start from the previous frame of the chunk
    warm = true;
  }
  Eigen::Map<Eigen::VectorXd> gt(g_.row(t).data(), shape_.cells());
  Eigen::Map<const Eigen::VectorXd> Gt(G_.row(t).data(), shape_.cells());
  reports_[static_cast<size_t>(t)] = solver.solve(Gt, gt, warm);
  completed_.fetch_add(1);
}

void BatchJob::start() {
  const Index T = G_.rows();
  const int nt = static_cast<int>(std::min<Index>(n_threads_, std::max<Index>(T, 1)));
  pool_ = std::make_unique<numerics::ThreadPool>(nt);
  for (int k = 0; k < nt; ++k) {
    done_.push_back(pool_->submit([this, k, nt, T](int) {
      Solver solver(shape_, opts_);  // one workspace per task (= per thread)
      if (streaming_) {
        const Index begin = T * k / nt, end = T * (k + 1) / nt;  // contiguous chunk
        for (Index t = begin; t < end && !cancel_.load(); ++t) solve_frame(solver, t, t == begin);
      } else {
        for (Index t; !cancel_.load() && (t = next_.fetch_add(1)) < T;) solve_frame(solver, t, true);
      }
    }).share());
  }
}

bool BatchJob::wait(double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (const auto& f : done_) {
    if (seconds < 0)
      f.wait();
    else if (f.wait_until(deadline) != std::future_status::ready)
      return false;
  }
  for (const auto& f : done_) f.get();  // rethrows what a task threw
  return true;
}

}  // namespace psmat::iecm
