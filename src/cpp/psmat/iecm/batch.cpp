#include "psmat/iecm/batch.hpp"

#include <algorithm>
#include <chrono>

#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

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
  for (auto& t : threads_)
    if (t.joinable()) t.join();
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
  running_.store(nt);
  for (int k = 0; k < nt; ++k) {
    threads_.emplace_back([this, k, nt, T] {
      Solver solver(shape_, opts_);  // one workspace per thread
      if (streaming_) {
        const Index begin = T * k / nt, end = T * (k + 1) / nt;  // contiguous chunk
        for (Index t = begin; t < end && !cancel_.load(); ++t) solve_frame(solver, t, t == begin);
      } else {
        for (Index t; !cancel_.load() && (t = next_.fetch_add(1)) < T;) solve_frame(solver, t, true);
      }
      running_.fetch_sub(1);
    });
  }
}

bool BatchJob::wait(double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (running_.load() > 0) {
    if (seconds >= 0 && std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  for (auto& t : threads_)
    if (t.joinable()) t.join();
  return true;
}

}  // namespace psmat::iecm
