#include "psmat/iecm/stream.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <utility>

#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

StreamSolver::StreamSolver(Shape shape, const SolveOptions& options, int n_threads,
                           std::size_t max_pending)
    : shape_(shape), opts_(options), max_pending_(std::max<std::size_t>(1, max_pending)) {
  const int n = std::max(1, n_threads);
  for (int k = 0; k < n; ++k) solvers_.push_back(std::make_unique<Solver>(shape_, opts_));
  pool_ = std::make_unique<numerics::ThreadPool>(n);
}

StreamSolver::~StreamSolver() {
  close();
  pool_.reset();  // solves the queued frames, then joins: before the queue and solvers go
}

std::uint64_t StreamSolver::push(const ConstVecRef& G, double timeout_s) {
  std::unique_lock<std::mutex> lock(mu_);
  auto space = [&] { return closed_ || next_in_ - next_out_ < max_pending_; };
  if (timeout_s < 0) {
    cv_space_.wait(lock, space);
  } else if (!cv_space_.wait_for(lock, std::chrono::duration<double>(timeout_s), space)) {
    return kFull;
  }
  if (closed_) throw std::runtime_error("StreamSolver: push() after close()");
  const std::uint64_t seq = next_in_++;
  queue_.emplace_back(seq, Eigen::VectorXd(G));
  lock.unlock();
  pool_->submit([this](int worker) { solve_next(worker); });  // no future: pop() collects the frame
  return seq;
}

void StreamSolver::solve_next(int worker) {
  Solver& solver = *solvers_[static_cast<size_t>(worker)];
  Eigen::VectorXd G, g(shape_.cells());
  StreamResult res;
  bool warm;
  {
    // the pool runs tasks in submission order and each takes the oldest frame: frames start
    // in push order
    std::lock_guard<std::mutex> lock(mu_);
    res.seq = queue_.front().first;
    G = std::move(queue_.front().second);
    queue_.pop_front();
    warm = have_latest_;
    if (warm) g = latest_g_;
  }
  try {
    res.report = solver.solve(G, g, warm);
    res.g = g;
  } catch (...) {
    res.error = std::current_exception();
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!res.error && res.report.converged() && (!have_latest_ || res.seq > latest_seq_)) {
      latest_g_ = g;
      latest_seq_ = res.seq;
      have_latest_ = true;
    }
    const std::uint64_t seq = res.seq;
    done_.emplace(seq, std::move(res));
  }
  cv_out_.notify_all();
}

bool StreamSolver::pop(StreamResult& out, double timeout_s) {
  std::unique_lock<std::mutex> lock(mu_);
  auto ready = [&] { return done_.count(next_out_) > 0 || (closed_ && next_out_ == next_in_); };
  if (timeout_s < 0) {
    cv_out_.wait(lock, ready);
  } else if (!cv_out_.wait_for(lock, std::chrono::duration<double>(timeout_s), ready)) {
    return false;
  }
  auto it = done_.find(next_out_);
  if (it == done_.end()) return false;  // closed and drained
  out = std::move(it->second);
  done_.erase(it);
  ++next_out_;
  cv_space_.notify_one();
  if (out.error) std::rethrow_exception(out.error);
  return true;
}

std::size_t StreamSolver::pending() const {
  std::lock_guard<std::mutex> lock(mu_);
  return static_cast<std::size_t>(next_in_ - next_out_);
}

void StreamSolver::close() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    closed_ = true;
  }
  cv_out_.notify_all();
  cv_space_.notify_all();
}

}  // namespace psmat::iecm
