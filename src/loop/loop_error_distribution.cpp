#include "scale_drift_slam/loop/loop_error_distribution.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "scale_drift_slam/geometry/lie_jacobians.h"
#include "scale_drift_slam/loop/pose_graph_residuals.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;

/// What differs between the modes: the group of a vertex and its tangent maps.
template <typename Group>
struct ModeTraits;

template <>
struct ModeTraits<SE3> {
  static constexpr int kDim = 6;
  static SE3 vertex(const Sim3& S) { return S.toSE3(); }
  static SE3 measurement(const Sim3& S) { return dropScale(S); }
  static Eigen::Matrix<double, 6, 6> information(const Matrix7d& L) { return se3Information(L); }
  static Eigen::Matrix<double, 6, 6> ad(const SE3::Tangent& x) { return geometry::adSE3(x); }
  static Eigen::Matrix<double, 6, 6> inverseLeftJacobian(const SE3::Tangent& x) {
    return geometry::inverseLeftJacobianSE3(x);
  }
  static Sim3 toSim3(const SE3& T) { return Sim3(T); }
};

template <>
struct ModeTraits<Sim3> {
  static constexpr int kDim = 7;
  static Sim3 vertex(const Sim3& S) { return S; }
  static Sim3 measurement(const Sim3& S) { return S; }
  static Matrix7d information(const Matrix7d& L) { return L; }
  static Matrix7d ad(const Sim3::Tangent& x) { return geometry::adSim3(x); }
  static Matrix7d inverseLeftJacobian(const Sim3::Tangent& x) {
    return geometry::inverseLeftJacobianSim3(x);
  }
  static Sim3 toSim3(const Sim3& S) { return S; }
};

/// Union-find over vertex indices.
class DisjointSets {
 public:
  explicit DisjointSets(int size) : parent_(size) { std::iota(parent_.begin(), parent_.end(), 0); }
  int find(int v) {
    while (parent_[v] != v) {
      parent_[v] = parent_[parent_[v]];
      v = parent_[v];
    }
    return v;
  }
  /// False when a and b are already in one set.
  bool join(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) {
      return false;
    }
    parent_[b] = a;
    return true;
  }

 private:
  std::vector<int> parent_;
};

template <typename Group>
class LoopDistributor {
 public:
  using Traits = ModeTraits<Group>;
  static constexpr int kDim = Traits::kDim;
  using Vector = Eigen::Matrix<double, kDim, 1>;
  using Matrix = Eigen::Matrix<double, kDim, kDim>;

  explicit LoopDistributor(const PoseGraph& graph);
  LoopErrorDistribution run(int passes);

 private:
  struct Edge {
    int from = 0, to = 0;
    Group M, M_inverse;  // the measurement of X_from X_to^-1 and its inverse
    Matrix information, covariance;
    EdgeKind kind = EdgeKind::kConsecutive;
  };
  /// One step along a forest path: the vertex whose parent edge it is, and the side (+1: b's).
  struct PathStep {
    int vertex = 0;
    double side = 1.0;
  };

  void buildForest();
  Vector residual(const Edge& edge) const {
    return (edge.M * X_[edge.to] * X_[edge.from].inverse()).log();
  }
  double chi2() const;
  std::vector<PathStep> forestPath(int a, int b) const;
  /// One Gauss-Newton step for all loops at once (see the header), then the poses recomposed.
  /// paths[c]: loop_chords_[c]'s forest path; users[v]: the (loop, step) pairs whose path holds
  /// v's parent edge. False (nothing changed) when the loops' system cannot be solved.
  bool distribute(const std::vector<std::vector<PathStep>>& paths,
                  const std::vector<std::vector<std::pair<int, int>>>& users);
  /// Poses from the roots with the forest edges' residuals tree_residual_.
  void composeFromRoots();

  std::vector<Group> X_;
  std::vector<char> fixed_;
  std::vector<Edge> edges_;
  // Spanning forest: breadth-first order from the roots (the fixed vertices), each vertex's
  // parent, the edge to it and its depth (roots: parent -1, depth 0).
  std::vector<int> order_, parent_, parent_edge_, depth_;
  std::vector<Vector> tree_residual_;  // residual of each vertex's parent edge ...
  std::vector<Vector> rest_residual_;  // ... and its value at the given poses
  std::vector<int> loop_chords_;
};

template <typename Group>
LoopDistributor<Group>::LoopDistributor(const PoseGraph& graph) {
  std::vector<map::KeyframeId> ids;
  for (const auto& [id, vertex] : graph.vertices()) {
    ids.push_back(id);
    X_.push_back(Traits::vertex(vertex.S_kf_world));
    fixed_.push_back(vertex.fixed ? 1 : 0);
  }
  const auto index = [&](map::KeyframeId id) {
    return static_cast<int>(std::lower_bound(ids.begin(), ids.end(), id) - ids.begin());
  };
  edges_.reserve(graph.edges().size());
  for (const PoseGraphEdge& input : graph.edges()) {
    Edge edge;
    edge.from = index(input.from);
    edge.to = index(input.to);
    edge.M = Traits::measurement(input.S_from_to);
    edge.M_inverse = edge.M.inverse();
    edge.information = Traits::information(input.information);
    edge.covariance = edge.information.llt().solve(Matrix::Identity());
    edge.kind = input.kind;
    edges_.push_back(edge);
  }
  buildForest();
}

template <typename Group>
void LoopDistributor<Group>::buildForest() {
  const int n = static_cast<int>(X_.size());
  // All fixed vertices start in one set (their corrections are all zero), so an edge between two
  // of them, or a path from one to another, closes a cycle like a loop.
  DisjointSets sets(n);
  int first_fixed = -1;
  for (int v = 0; v < n; ++v) {
    if (fixed_[v]) {
      first_fixed < 0 ? void(first_fixed = v) : void(sets.join(first_fixed, v));
    }
  }
  // Consecutive (odometry) edges first, then co-visibility, then loops: the forest follows the
  // odometry and the loop edges become the chords.
  std::vector<int> by_kind(edges_.size());
  std::iota(by_kind.begin(), by_kind.end(), 0);
  std::stable_sort(by_kind.begin(), by_kind.end(), [&](int a, int b) {
    return static_cast<int>(edges_[a].kind) < static_cast<int>(edges_[b].kind);
  });
  std::vector<std::vector<int>> tree_edges(n);
  for (const int k : by_kind) {
    const Edge& edge = edges_[k];
    if (sets.join(edge.from, edge.to)) {
      tree_edges[edge.from].push_back(k);
      tree_edges[edge.to].push_back(k);
    } else if (edge.kind == EdgeKind::kLoop) {
      loop_chords_.push_back(k);
    }
  }
  parent_.assign(n, -1);
  parent_edge_.assign(n, -1);
  depth_.assign(n, 0);
  std::vector<char> reached(fixed_);
  for (int v = 0; v < n; ++v) {
    if (fixed_[v]) {
      order_.push_back(v);
    }
  }
  for (std::size_t next = 0; next < order_.size(); ++next) {
    const int v = order_[next];
    for (const int k : tree_edges[v]) {
      const int u = edges_[k].from == v ? edges_[k].to : edges_[k].from;
      if (!reached[u]) {
        reached[u] = 1;
        parent_[u] = v;
        parent_edge_[u] = k;
        depth_[u] = depth_[v] + 1;
        order_.push_back(u);
      }
    }
  }
  tree_residual_.assign(n, Vector::Zero());
  for (int v = 0; v < n; ++v) {
    if (parent_edge_[v] >= 0) {
      tree_residual_[v] = residual(edges_[parent_edge_[v]]);
    }
  }
  rest_residual_ = tree_residual_;
}

template <typename Group>
double LoopDistributor<Group>::chi2() const {
  double sum = 0.0;
  for (const Edge& edge : edges_) {
    const Vector r = residual(edge);
    sum += r.dot(edge.information * r);
  }
  return sum;
}

template <typename Group>
std::vector<typename LoopDistributor<Group>::PathStep> LoopDistributor<Group>::forestPath(
    int a, int b) const {
  // Climb from the deeper end until both meet, or both are roots (fixed: no correction).
  std::vector<PathStep> path;
  while (a != b && (parent_[a] >= 0 || parent_[b] >= 0)) {
    if (depth_[a] >= depth_[b] && parent_[a] >= 0) {
      path.push_back({a, -1.0});
      a = parent_[a];
    } else {
      path.push_back({b, 1.0});
      b = parent_[b];
    }
  }
  return path;
}

template <typename Group>
bool LoopDistributor<Group>::distribute(
    const std::vector<std::vector<PathStep>>& paths,
    const std::vector<std::vector<std::pair<int, int>>>& users) {
  const int num_loops = static_cast<int>(paths.size());
  // Per loop c: G_ce = d r_c / d d_e along its path, and the right-hand side r_c - sum_e G_ce
  // (r_e - r_e^rest) (the chord residual with the forest edges back at rest, linearised).
  std::vector<std::vector<Matrix>> G(num_loops);
  Eigen::MatrixXd system = Eigen::MatrixXd::Zero(kDim * num_loops, kDim * num_loops);
  Eigen::VectorXd rhs(kDim * num_loops);
  for (int c = 0; c < num_loops; ++c) {
    const Edge& chord = edges_[loop_chords_[c]];
    const Vector r_c = residual(chord);
    // dr_c / d eps_b.
    const Matrix chord_map = Traits::inverseLeftJacobian(r_c) * (chord.M * X_[chord.to]).adjoint();
    Vector bent = Vector::Zero();
    for (const PathStep& step : paths[c]) {
      const Edge& edge = edges_[parent_edge_[step.vertex]];
      const double sign = step.side * (edge.to == step.vertex ? 1.0 : -1.0);
      // d eps_child - d eps_parent = s_e Adj(M_e X_to)^-1 Jl(r_e) d_e, with Jl(r) = I + ad(r) / 2
      // + O(r^2): forest residuals are small and the guess need not be exact (the exact Jl,
      // a 12-term series, made the guess 8 times slower for the same chi2 on the Keble loop).
      const Matrix to_world = (edge.M * X_[edge.to]).inverse().adjoint();
      const Matrix eps_map = to_world + 0.5 * (to_world * Traits::ad(tree_residual_[step.vertex]));
      G[c].push_back(sign * (chord_map * eps_map));
      bent.noalias() += G[c].back() * (tree_residual_[step.vertex] - rest_residual_[step.vertex]);
    }
    rhs.segment<kDim>(kDim * c) = r_c - bent;
    system.block<kDim, kDim>(kDim * c, kDim * c) = chord.covariance;
  }
  // (Lambda_c^-1 delta_cc' + A_cc') mu = rhs, A_cc' = sum over shared edges G_ce Lambda_e^-1
  // G_c'e^T: symmetric positive definite.
  for (std::size_t v = 0; v < users.size(); ++v) {
    if (users[v].empty()) continue;
    const Matrix& covariance = edges_[parent_edge_[v]].covariance;
    for (const auto& [c, k] : users[v]) {
      const Matrix GC = G[c][k] * covariance;
      for (const auto& [c2, k2] : users[v]) {
        system.block<kDim, kDim>(kDim * c, kDim * c2).noalias() += GC * G[c2][k2].transpose();
      }
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(system);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::VectorXd mu = llt.solve(rhs);
  if (!mu.allFinite()) return false;
  for (std::size_t v = 0; v < users.size(); ++v) {
    if (users[v].empty()) continue;
    Vector GT_mu = Vector::Zero();
    for (const auto& [c, k] : users[v])
      GT_mu.noalias() += G[c][k].transpose() * mu.segment<kDim>(kDim * c);
    tree_residual_[v] = rest_residual_[v] - edges_[parent_edge_[v]].covariance * GT_mu;
  }
  composeFromRoots();
  return true;
}

template <typename Group>
void LoopDistributor<Group>::composeFromRoots() {
  for (const int v : order_) {
    const int p = parent_[v];
    if (p < 0) {
      continue;
    }
    const Edge& edge = edges_[parent_edge_[v]];
    const Group E = Group::exp(tree_residual_[v]);  // = M X_to X_from^-1
    X_[v] =
        edge.from == p ? Group(edge.M_inverse * E * X_[p]) : Group(E.inverse() * edge.M * X_[p]);
  }
}

template <typename Group>
LoopErrorDistribution LoopDistributor<Group>::run(int passes) {
  LoopErrorDistribution result;
  result.given_chi2 = chi2();
  result.chi2 = result.given_chi2;
  // Loops between two fixed vertices (an empty path) cannot move anything.
  std::vector<int> chords;
  std::vector<std::vector<PathStep>> paths;
  for (const int k : loop_chords_) {
    std::vector<PathStep> path = forestPath(edges_[k].from, edges_[k].to);
    if (path.empty()) continue;
    chords.push_back(k);
    paths.push_back(std::move(path));
  }
  loop_chords_ = chords;
  std::vector<std::vector<std::pair<int, int>>> users(X_.size());
  for (std::size_t c = 0; c < paths.size(); ++c) {
    for (std::size_t k = 0; k < paths[c].size(); ++k)
      users[paths[c][k].vertex].emplace_back(static_cast<int>(c), static_cast<int>(k));
  }
  // A pass costs the loops' paths, the pairs of loops on each shared edge, composing every pose
  // and the dense solve; beyond about four LM iterations' worth of work (many long, overlapping
  // loops) the guess is not worth it.
  std::size_t work = X_.size() + paths.size() * paths.size() * paths.size();
  for (const auto& on_edge : users)
    work += on_edge.size() * on_edge.size();
  if (paths.empty() || passes * work > 4 * (X_.size() + edges_.size())) {
    return result;
  }
  for (int pass = 0; pass < passes; ++pass) {
    if (!distribute(paths, users)) return result;
  }
  const double guess_chi2 = chi2();
  if (!(guess_chi2 < result.given_chi2)) {
    return result;
  }
  result.loops = static_cast<int>(loop_chords_.size());
  result.chi2 = guess_chi2;
  result.S_kf_world.reserve(X_.size());
  for (const Group& X : X_) {
    result.S_kf_world.push_back(Traits::toSim3(X));
  }
  return result;
}

}  // namespace

LoopErrorDistribution distributeLoopErrors(const PoseGraph& graph, PoseGraphMode mode, int passes) {
  if (passes < 1) {
    throw std::invalid_argument("loop error distribution: passes must be >= 1");
  }
  if (mode == PoseGraphMode::kSim3) {
    return LoopDistributor<Sim3>(graph).run(passes);
  }
  return LoopDistributor<SE3>(graph).run(passes);
}

}  // namespace scale_drift_slam::loop
