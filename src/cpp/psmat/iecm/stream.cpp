#include "psmat/iecm/stream.hpp"

#include <chrono>
#include <stdexcept>

#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

StreamSolver::StreamSolver(Shape shape, const SolveOptions& options, int n_threads,
                           std::size_t max_pending)
    : shape_(shape), opts_(options), max_pending_(std::max<std::size_t>(1, max_pending)) {
  for (int k = 0; k < std::max(1, n_threads); ++k) threads_.emplace_back([this] { worker(); });
}

StreamSolver::~StreamSolver() {
  close();
  for (auto& t : threads_)
    if (t.joinable()) t.join();
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
  cv_in_.notify_one();
  return seq;
}

void StreamSolver::worker() {
  Solver solver(shape_, opts_);
  Eigen::VectorXd G, g(shape_.cells());
  for (;;) {
    std::uint64_t seq;
    bool warm;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_in_.wait(lock, [&] { return closed_ || !queue_.empty(); });
      if (queue_.empty()) return;  // closed and drained
      seq = queue_.front().first;
      G = std::move(queue_.front().second);
      queue_.pop_front();
      warm = have_latest_;
      if (warm) g = latest_g_;
    }
    StreamResult res;
    res.seq = seq;
    res.report = solver.solve(G, g, warm);
    res.g = g;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (res.report.converged() && (!have_latest_ || seq > latest_seq_)) {
        latest_g_ = g;
        latest_seq_ = seq;
        have_latest_ = true;
      }
      done_.emplace(seq, std::move(res));
    }
    cv_out_.notify_all();
  }
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
  cv_in_.notify_all();
  cv_out_.notify_all();
  cv_space_.notify_all();
}

}  // namespace psmat::iecm
