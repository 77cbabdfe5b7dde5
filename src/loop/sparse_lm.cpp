#include "sparse_lm.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include "edge_linearization.h"
#include "scale_drift_slam/loop/pose_graph_residuals.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;

/// The vertex pose in the solver's group (SE(3) mode: rotation and t / s, the camera centre kept).
template <typename Group>
Group toGroup(const Sim3& S);
template <>
Sim3 toGroup<Sim3>(const Sim3& S) {
  return S;
}
template <>
SE3 toGroup<SE3>(const Sim3& S) {
  return S.toSE3();
}
Sim3 toSim3(const Sim3& S) {
  return S;
}
Sim3 toSim3(const SE3& T) {
  return Sim3(T);
}
/// The edge measurement and information in the solver's group (SE(3): scale dropped, the sigma
/// row and column of the information removed).
Sim3 measurementOf(const Sim3& S, const Sim3*) {
  return S;
}
SE3 measurementOf(const Sim3& S, const SE3*) {
  return dropScale(S);
}
Matrix7d informationOf(const Matrix7d& information, const Sim3*) {
  return information;
}
Eigen::Matrix<double, 6, 6> informationOf(const Matrix7d& information, const SE3*) {
  return se3Information(information);
}

/// Levenberg-Marquardt over the free vertices: (H + mu D) delta = -g with H = J^T J, g = J^T r,
/// D = diag(H) clamped to [1e-6, 1e32], mu = 1 / trust radius updated as in Ceres (Nielsen).
template <typename Group>
class SparseLM {
 public:
  static constexpr int N = GroupTraits<Group>::kTangent;
  using Matrix = Eigen::Matrix<double, N, N>;
  using Vector = Eigen::Matrix<double, N, 1>;

  SparseLM(const std::map<map::KeyframeId, PoseGraphVertex>& vertices,
           const std::vector<PoseGraphEdge>& edges);
  PoseGraphResult solve(const PoseGraphOptions& options);

 private:
  struct Edge {
    int from = 0, to = 0;            ///< Vertex indices.
    int var_from = -1, var_to = -1;  ///< Variable indices (-1: fixed vertex).
    int block = -1;                  ///< Off-diagonal block of H, when both are free.
    EdgeModel<Group> model;
  };

  void buildPattern();
  double cost(const std::vector<Group>& poses) const;
  double linearize();
  bool solveDamped(double mu, Eigen::VectorXd* delta);
  std::vector<Group> moved(const Eigen::VectorXd& delta) const;

  std::vector<map::KeyframeId> ids_;
  std::vector<Group> poses_;
  std::vector<int> variable_;  ///< Per vertex.
  int num_variables_ = 0;
  std::vector<Edge> edges_;
  std::vector<std::pair<int, int>> off_blocks_;  ///< (row variable, column variable), row > col.
  std::vector<Matrix> diagonal_, off_diagonal_;
  Eigen::VectorXd gradient_;
  Eigen::SparseMatrix<double> system_;  ///< Lower triangle of H + mu D.
  std::vector<int> diagonal_start_;     ///< valuePtr index of each diagonal block column.
  std::vector<int> off_start_;          ///< ... of each off-diagonal block column.
  Eigen::CholmodDecomposition<Eigen::SparseMatrix<double>, Eigen::Lower> cholesky_;
  bool analysed_ = false;
};

template <typename Group>
SparseLM<Group>::SparseLM(const std::map<map::KeyframeId, PoseGraphVertex>& vertices,
                          const std::vector<PoseGraphEdge>& edges) {
  std::map<map::KeyframeId, int> index;
  for (const auto& [id, vertex] : vertices) {
    index[id] = static_cast<int>(ids_.size());
    ids_.push_back(id);
    poses_.push_back(toGroup<Group>(vertex.S_kf_world));
    variable_.push_back(vertex.fixed ? -1 : num_variables_++);
  }
  std::map<std::pair<int, int>, int> block_of;
  for (const PoseGraphEdge& edge : edges) {
    const Group* tag = nullptr;
    Edge e{index.at(edge.from),
           index.at(edge.to),
           -1,
           -1,
           -1,
           EdgeModel<Group>(measurementOf(edge.S_from_to, tag),
                            sqrtInformation<N>(informationOf(edge.information, tag)))};
    e.var_from = variable_[e.from];
    e.var_to = variable_[e.to];
    if (e.var_from >= 0 && e.var_to >= 0) {
      const std::pair<int, int> key(std::max(e.var_from, e.var_to), std::min(e.var_from, e.var_to));
      const auto inserted = block_of.emplace(key, static_cast<int>(off_blocks_.size()));
      if (inserted.second) off_blocks_.push_back(key);
      e.block = inserted.first->second;
    }
    edges_.push_back(std::move(e));
  }
  diagonal_.assign(num_variables_, Matrix::Zero());
  off_diagonal_.assign(off_blocks_.size(), Matrix::Zero());
  gradient_.setZero(static_cast<Eigen::Index>(num_variables_) * N);
  buildPattern();
}

/// The lower triangle of the block pattern, and where each block column starts in valuePtr
/// (rows of a block are contiguous in a compressed column).
template <typename Group>
void SparseLM<Group>::buildPattern() {
  std::vector<Eigen::Triplet<double>> triplets;
  for (int v = 0; v < num_variables_; ++v) {
    for (int c = 0; c < N; ++c) {
      for (int r = c; r < N; ++r)
        triplets.emplace_back(v * N + r, v * N + c, 0.0);
    }
  }
  for (const auto& [row, col] : off_blocks_) {
    for (int c = 0; c < N; ++c) {
      for (int r = 0; r < N; ++r)
        triplets.emplace_back(row * N + r, col * N + c, 0.0);
    }
  }
  const Eigen::Index size = static_cast<Eigen::Index>(num_variables_) * N;
  system_.resize(size, size);
  system_.setFromTriplets(triplets.begin(), triplets.end());
  system_.makeCompressed();
  const int* outer = system_.outerIndexPtr();
  const int* inner = system_.innerIndexPtr();
  diagonal_start_.resize(static_cast<std::size_t>(num_variables_) * N);
  for (int column = 0; column < num_variables_ * N; ++column) {
    diagonal_start_[column] = outer[column];  // the first stored row is the diagonal
  }
  off_start_.resize(off_blocks_.size() * N);
  for (std::size_t b = 0; b < off_blocks_.size(); ++b) {
    for (int c = 0; c < N; ++c) {
      const int column = off_blocks_[b].second * N + c;
      off_start_[b * N + c] =
          static_cast<int>(std::lower_bound(inner + outer[column], inner + outer[column + 1],
                                            off_blocks_[b].first * N) -
                           inner);
    }
  }
}

template <typename Group>
double SparseLM<Group>::cost(const std::vector<Group>& poses) const {
  double sum = 0.0;
  Vector r;
  for (const Edge& e : edges_) {
    e.model.linearize(poses[e.from], poses[e.to], &r, nullptr, nullptr);
    sum += r.squaredNorm();
  }
  return sum;
}

/// Accumulates H and g at the current poses; returns the cost sum |r|^2.
template <typename Group>
double SparseLM<Group>::linearize() {
  for (Matrix& block : diagonal_)
    block.setZero();
  for (Matrix& block : off_diagonal_)
    block.setZero();
  gradient_.setZero();
  double sum = 0.0;
  Vector r;
  Matrix J_from, J_to;
  for (const Edge& e : edges_) {
    e.model.linearize(poses_[e.from], poses_[e.to], &r, &J_from, &J_to);
    sum += r.squaredNorm();
    if (e.var_from >= 0) {
      diagonal_[e.var_from].noalias() += J_from.transpose() * J_from;
      gradient_.template segment<N>(e.var_from * N).noalias() += J_from.transpose() * r;
    }
    if (e.var_to >= 0) {
      diagonal_[e.var_to].noalias() += J_to.transpose() * J_to;
      gradient_.template segment<N>(e.var_to * N).noalias() += J_to.transpose() * r;
    }
    if (e.block >= 0) {
      if (e.var_from > e.var_to) {
        off_diagonal_[e.block].noalias() += J_from.transpose() * J_to;
      } else {
        off_diagonal_[e.block].noalias() += J_to.transpose() * J_from;
      }
    }
  }
  return sum;
}

template <typename Group>
bool SparseLM<Group>::solveDamped(double mu, Eigen::VectorXd* delta) {
  double* values = system_.valuePtr();
  for (int v = 0; v < num_variables_; ++v) {
    const Matrix& H = diagonal_[v];
    for (int c = 0; c < N; ++c) {
      double* column = values + diagonal_start_[v * N + c];
      for (int r = c; r < N; ++r)
        column[r - c] = H(r, c);
      column[0] += mu * std::clamp(H(c, c), 1e-6, 1e32);
    }
  }
  for (std::size_t b = 0; b < off_blocks_.size(); ++b) {
    for (int c = 0; c < N; ++c) {
      double* column = values + off_start_[b * N + c];
      for (int r = 0; r < N; ++r)
        column[r] = off_diagonal_[b](r, c);
    }
  }
  if (!analysed_) {
    cholesky_.analyzePattern(system_);
    analysed_ = true;
  }
  cholesky_.factorize(system_);
  if (cholesky_.info() != Eigen::Success) return false;
  *delta = -cholesky_.solve(gradient_);
  return cholesky_.info() == Eigen::Success && delta->allFinite();
}

template <typename Group>
std::vector<Group> SparseLM<Group>::moved(const Eigen::VectorXd& delta) const {
  std::vector<Group> poses = poses_;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (variable_[i] < 0) continue;
    poses[i] = Group::exp(delta.template segment<N>(variable_[i] * N)) * poses[i];
  }
  return poses;
}

template <typename Group>
PoseGraphResult SparseLM<Group>::solve(const PoseGraphOptions& options) {
  PoseGraphResult result;
  double current = linearize();
  result.initial_chi2 = current;
  double mu = options.initial_damping, nu = 2.0;
  result.termination = "NO_CONVERGENCE: maximum number of iterations reached";
  Eigen::VectorXd delta;
  for (int iteration = 0; iteration < options.max_iterations && num_variables_ > 0; ++iteration) {
    ++result.iterations;
    if (gradient_.lpNorm<Eigen::Infinity>() <= options.gradient_tolerance) {
      result.converged = true;
      result.termination = "CONVERGENCE: gradient tolerance reached";
      break;
    }
    if (!solveDamped(mu, &delta)) {
      mu *= nu;
      nu *= 2.0;
      if (mu > 1e32) throw std::runtime_error("pose graph: the normal equations stay singular");
      continue;
    }
    std::vector<Group> candidate = moved(delta);
    const double candidate_cost = cost(candidate);
    double damping_term = 0.0;
    for (int v = 0; v < num_variables_; ++v) {
      const Vector d = delta.template segment<N>(v * N);
      damping_term +=
          mu * d.dot(diagonal_[v].diagonal().cwiseMax(1e-6).cwiseMin(1e32).cwiseProduct(d));
    }
    const double model_decrease = -gradient_.dot(delta) + damping_term;
    const double rho = (current - candidate_cost) / model_decrease;
    if (!(rho > 1e-3) || !std::isfinite(candidate_cost)) {
      mu *= nu;
      nu *= 2.0;
      continue;
    }
    double parameter_norm = 0.0;
    for (const Group& pose : poses_)
      parameter_norm += pose.translation().squaredNorm() + 1.0;
    poses_ = std::move(candidate);
    const double decrease = current - candidate_cost;
    current = linearize();
    mu *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
    nu = 2.0;
    if (decrease <= options.function_tolerance * (current + decrease)) {
      result.converged = true;
      result.termination = "CONVERGENCE: function tolerance reached";
      break;
    }
    if (delta.norm() <=
        options.parameter_tolerance * (std::sqrt(parameter_norm) + options.parameter_tolerance)) {
      result.converged = true;
      result.termination = "CONVERGENCE: parameter tolerance reached";
      break;
    }
  }
  if (num_variables_ == 0) {
    result.converged = true;
    result.termination = "CONVERGENCE: no free vertex";
  }
  result.final_chi2 = current;
  for (std::size_t i = 0; i < ids_.size(); ++i)
    result.S_kf_world.emplace(ids_[i], toSim3(poses_[i]));
  return result;
}

}  // namespace

PoseGraphResult optimizeWithSparseLM(const std::map<map::KeyframeId, PoseGraphVertex>& vertices,
                                     const std::vector<PoseGraphEdge>& edges,
                                     const PoseGraphOptions& options) {
  if (options.mode == PoseGraphMode::kSim3) return SparseLM<Sim3>(vertices, edges).solve(options);
  return SparseLM<SE3>(vertices, edges).solve(options);
}

}  // namespace scale_drift_slam::loop
