#pragma once
// The pose graph of loop-closure correction (doc/algorithm.md, "Loop closure correction"):
// keyframe poses as vertices, relative constraints as edges, solved with Ceres
// (Levenberg-Marquardt, sparse Cholesky through SuiteSparse) in one of two modes:
//   Sim(3): vertices are similarities S_i = S_kf_world, residual r_ij = log_Sim3(S_ij S_j S_i^-1)
//           with a 7x7 information matrix; a loop edge carries its measured relative scale.
//   SE(3):  the baseline the paper compares against: the same graph with rigid transforms,
//           r_ij = log_SE3(T_ij T_j T_i^-1), 6x6 information; every scale is dropped.
// Edge (i = from, j = to) measures S_ij = S_i S_j^-1. Updates are left-multiplied,
// S <- exp(delta) S.

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::loop {

using Matrix7d = Eigen::Matrix<double, 7, 7>;

enum class PoseGraphMode { kSim3, kSE3 };
enum class EdgeKind { kConsecutive, kCovisibility, kLoop };
/// How the edge residuals give Ceres their Jacobians: closed form (the default, fast) or Ceres
/// automatic differentiation through log/exp (the reference; several times slower).
enum class PoseGraphJacobians { kAnalytic, kAutoDiff };
/// The sparse linear solver of each LM step (the normal equations' Cholesky factorisation).
enum class PoseGraphLinearSolver { kSuiteSparseCholesky, kEigenSparseCholesky };

std::string toString(PoseGraphMode mode);
std::string toString(EdgeKind kind);
std::string toString(PoseGraphJacobians jacobians);
/// Parse "sim3"/"se3", "analytic"/"autodiff"; throw std::invalid_argument naming the choices.
PoseGraphMode parsePoseGraphMode(const std::string& name);
PoseGraphJacobians parsePoseGraphJacobians(const std::string& name);

/// Solver settings of the pose-graph optimisation. The defaults run LM to full convergence.
struct PoseGraphOptions {
  PoseGraphMode mode = PoseGraphMode::kSim3;
  PoseGraphJacobians jacobians = PoseGraphJacobians::kAnalytic;
  PoseGraphLinearSolver linear_solver = PoseGraphLinearSolver::kSuiteSparseCholesky;
  /// Passes of the initial guess that spreads each loop edge's error along the odometry before LM
  /// (loop/loop_error_distribution.h; the given poses are kept if it is no better); 0: LM starts
  /// from the given poses. 3 saves 3 of the 6-7 LM iterations on the Keble graph.
  int loop_error_passes = 3;
  int max_iterations = 100;  ///< LM iterations (accepted and rejected steps).
  /// Stop when |d chi2| / chi2 falls below this. 1e-10 leaves the Keble camera centres within
  /// 1.3e-6 map units of the 1e-12 solution (one or two iterations earlier).
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;   ///< Stop when the max-norm of the gradient falls below.
  double parameter_tolerance = 1e-12;  ///< Stop when |dx| < tol (|x| + tol).
  /// LM damping mu of the first step, (J^T J + mu diag(J^T J)) dx = -J^T r (Ceres: the initial
  /// trust-region radius is 1 / mu). Pose graphs start from odometry, close to the optimum: a
  /// small value takes nearly Gauss-Newton steps at once (Ceres' default 1e-4 costs 2 to 3
  /// iterations more on the Keble graph).
  double initial_damping = 1e-6;
  int num_threads = 1;
  bool log_progress = false;  ///< Print Ceres' per-iteration progress and report to stdout.

  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

struct PoseGraphVertex {
  geometry::Sim3 S_kf_world;  ///< Maps world points into the keyframe (scale 1 for a rigid pose).
  bool fixed = false;         ///< Held constant: fixes the gauge (7 DoF in Sim(3), 6 in SE(3)).
};

struct PoseGraphEdge {
  map::KeyframeId from = 0;
  map::KeyframeId to = 0;
  geometry::Sim3 S_from_to;  ///< The measurement of S_from S_to^-1 (paper: S_ij, i=from, j=to).
  /// Information of the residual in the tangent order (omega, sigma, upsilon); symmetric positive
  /// definite. SE(3) mode uses it with the sigma row and column removed.
  Matrix7d information = Matrix7d::Identity();
  EdgeKind kind = EdgeKind::kConsecutive;
};

struct PoseGraphResult {
  /// Every vertex after the optimisation (scale exactly 1 in SE(3) mode).
  std::map<map::KeyframeId, geometry::Sim3> S_kf_world;
  int iterations = 0;  ///< LM steps taken (accepted and rejected).
  /// Loop edges whose error the initial guess distributed (0: LM started from the given poses).
  int guess_loops = 0;
  double initial_chi2 = 0.0;  ///< sum_edges r^T Lambda r of the given vertices ...
  double guess_chi2 = 0.0;    ///< ... where LM started (the loop errors distributed) ...
  double final_chi2 = 0.0;    ///< ... and at the end.
  double time_s = 0.0;        ///< Wall time of optimize(), building the problem included.
  std::string termination;    ///< Ceres' termination type and message.
  bool converged = false;     ///< Ceres reached a convergence tolerance (not the iteration cap).
};

/// A graph of keyframe similarities and relative constraints. Plain data plus validation: every
/// add* checks its input and throws std::invalid_argument with the reason, so a built graph is
/// always consistent. optimize() does not modify the graph, so one graph can be solved in both
/// modes. Not thread-safe for concurrent modification; optimize() may run concurrently.
class PoseGraph {
 public:
  /// Throws on a duplicate id or a non-finite pose.
  void addVertex(map::KeyframeId id, const geometry::Sim3& S_kf_world, bool fixed = false);
  /// Throws on an unknown id.
  void setFixed(map::KeyframeId id, bool fixed = true);
  /// Throws on a missing vertex, from == to, a non-finite or non-positive-scale measurement, or
  /// an information matrix that is not finite, symmetric and positive definite.
  void addEdge(const PoseGraphEdge& edge);

  const std::map<map::KeyframeId, PoseGraphVertex>& vertices() const { return vertices_; }
  const std::vector<PoseGraphEdge>& edges() const { return edges_; }
  std::size_t numFixed() const;
  std::size_t numEdges(EdgeKind kind) const;

  /// sum_edges r^T Lambda r of the given poses (default: the vertices) in the given mode.
  double chi2(PoseGraphMode mode) const;
  double chi2(PoseGraphMode mode,
              const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world) const;

  /// Solves the graph. Throws std::invalid_argument when the options are invalid, when no vertex
  /// is fixed or a vertex is not connected to a fixed one (its pose would be undetermined), and
  /// std::runtime_error when Ceres fails.
  PoseGraphResult optimize(const PoseGraphOptions& options) const;

 private:
  void checkGauge() const;

  std::map<map::KeyframeId, PoseGraphVertex> vertices_;
  std::vector<PoseGraphEdge> edges_;
};

/// r = log_Sim3(S_ij S_j S_i^-1), the paper's edge residual (unweighted).
geometry::Sim3::Tangent sim3EdgeResidual(const geometry::Sim3& S_ij, const geometry::Sim3& S_i,
                                         const geometry::Sim3& S_j);
/// r = log_SE3(T_ij T_j T_i^-1).
geometry::SE3::Tangent se3EdgeResidual(const geometry::SE3& T_ij, const geometry::SE3& T_i,
                                       const geometry::SE3& T_j);

/// A rigid relative pose with a relative scale s as the similarity [s R, t; 0 1] (how a loop
/// edge carries its measured scale). Throws std::invalid_argument for s <= 0 or a non-finite s.
geometry::Sim3 similarityWithScale(const geometry::SE3& T, double scale);

/// The rigid transform of a similarity with its scale dropped: [R, t] (the measurement an
/// SE(3) graph uses for an edge).
geometry::SE3 dropScale(const geometry::Sim3& S);

/// The camera centre in the world of a keyframe pose S_kf_world: -R^T t / s.
Eigen::Vector3d cameraCentre(const geometry::Sim3& S_kf_world);

}  // namespace scale_drift_slam::loop
