#include "scale_drift_slam/loop/pose_graph.h"

#include <cmath>
#include <cstdio>
#include <deque>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>

#include <ceres/ceres.h>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/loop/loop_error_distribution.h"
#include "scale_drift_slam/loop/pose_graph_residuals.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;

bool isFinite(const Sim3& S) {
  return S.rotation().coeffs().allFinite() && S.translation().allFinite() &&
         std::isfinite(S.logScale());
}

std::string edgeName(const PoseGraphEdge& edge) {
  return toString(edge.kind) + " edge " + std::to_string(edge.from) + " -> " +
         std::to_string(edge.to);
}

/// The parameter block of a vertex in the given mode (SE(3): the similarity's rigid pose,
/// translation t/s so that the camera centre is kept).
void toParameters(PoseGraphMode mode, const Sim3& S, double* data) {
  if (mode == PoseGraphMode::kSim3) {
    S.toData(data);
  } else {
    S.toSE3().toData(data);
  }
}

Sim3 fromParameters(PoseGraphMode mode, const double* data) {
  if (mode == PoseGraphMode::kSim3) {
    return Sim3::fromData(data);
  }
  return Sim3(SE3::fromData(data));
}

ceres::Solver::Options solverOptions(const PoseGraphOptions& options) {
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.sparse_linear_algebra_library_type =
      options.linear_solver == PoseGraphLinearSolver::kSuiteSparseCholesky ? ceres::SUITE_SPARSE
                                                                           : ceres::EIGEN_SPARSE;
  solver.max_num_iterations = options.max_iterations;
  solver.initial_trust_region_radius = 1.0 / options.initial_damping;
  solver.function_tolerance = options.function_tolerance;
  solver.gradient_tolerance = options.gradient_tolerance;
  solver.parameter_tolerance = options.parameter_tolerance;
  solver.num_threads = options.num_threads;
  solver.logging_type = options.log_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  solver.minimizer_progress_to_stdout = options.log_progress;
  return solver;
}

}  // namespace

std::string toString(PoseGraphMode mode) {
  return mode == PoseGraphMode::kSim3 ? "sim3" : "se3";
}

std::string toString(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kConsecutive:
      return "consecutive";
    case EdgeKind::kCovisibility:
      return "covisibility";
    case EdgeKind::kLoop:
      return "loop";
  }
  return "unknown";
}

std::string toString(PoseGraphJacobians jacobians) {
  return jacobians == PoseGraphJacobians::kAnalytic ? "analytic" : "autodiff";
}

PoseGraphMode parsePoseGraphMode(const std::string& name) {
  if (name == "sim3") {
    return PoseGraphMode::kSim3;
  }
  if (name == "se3") {
    return PoseGraphMode::kSE3;
  }
  throw std::invalid_argument("unknown pose-graph mode '" + name + "' (sim3 or se3)");
}

PoseGraphJacobians parsePoseGraphJacobians(const std::string& name) {
  if (name == "analytic") {
    return PoseGraphJacobians::kAnalytic;
  }
  if (name == "autodiff") {
    return PoseGraphJacobians::kAutoDiff;
  }
  throw std::invalid_argument("unknown Jacobian choice '" + name + "' (analytic or autodiff)");
}

void PoseGraphOptions::validate() const {
  if (max_iterations < 1) {
    throw std::invalid_argument("pose graph: max_iterations must be >= 1");
  }
  for (const auto& [name, value] :
       {std::pair<const char*, double>{"function_tolerance", function_tolerance},
        {"gradient_tolerance", gradient_tolerance},
        {"parameter_tolerance", parameter_tolerance}}) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      throw std::invalid_argument(std::string("pose graph: ") + name + " must be finite and >= 0");
    }
  }
  if (loop_error_passes < 0) {
    throw std::invalid_argument("pose graph: loop_error_passes must be >= 0");
  }
  if (num_threads < 1) {
    throw std::invalid_argument("pose graph: num_threads must be >= 1");
  }
  if (!(initial_damping > 0.0) || !std::isfinite(initial_damping)) {
    throw std::invalid_argument("pose graph: initial_damping must be finite and > 0");
  }
}

void PoseGraph::addVertex(map::KeyframeId id, const Sim3& S_kf_world, bool fixed) {
  if (vertices_.count(id)) {
    throw std::invalid_argument("pose graph: vertex " + std::to_string(id) + " added twice");
  }
  if (!isFinite(S_kf_world)) {
    throw std::invalid_argument("pose graph: vertex " + std::to_string(id) +
                                " has a non-finite pose or scale");
  }
  vertices_.emplace(id, PoseGraphVertex{S_kf_world, fixed});
}

void PoseGraph::setFixed(map::KeyframeId id, bool fixed) {
  const auto it = vertices_.find(id);
  if (it == vertices_.end()) {
    throw std::invalid_argument("pose graph: cannot fix missing vertex " + std::to_string(id));
  }
  it->second.fixed = fixed;
}

void PoseGraph::addEdge(const PoseGraphEdge& edge) {
  for (const map::KeyframeId id : {edge.from, edge.to}) {
    if (!vertices_.count(id)) {
      throw std::invalid_argument("pose graph: " + edgeName(edge) + " refers to missing vertex " +
                                  std::to_string(id));
    }
  }
  if (edge.from == edge.to) {
    throw std::invalid_argument("pose graph: " + edgeName(edge) + " joins a vertex to itself");
  }
  if (!isFinite(edge.S_from_to)) {
    throw std::invalid_argument("pose graph: " + edgeName(edge) +
                                " has a non-finite measurement or a non-positive scale");
  }
  try {
    makeEdgeCost(PoseGraphMode::kSim3, PoseGraphJacobians::kAnalytic, edge.S_from_to,
                 edge.information);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("pose graph: " + edgeName(edge) + ": " + e.what());
  }
  edges_.push_back(edge);
}

std::size_t PoseGraph::numFixed() const {
  std::size_t count = 0;
  for (const auto& entry : vertices_) {
    count += entry.second.fixed ? 1 : 0;
  }
  return count;
}

std::size_t PoseGraph::numEdges(EdgeKind kind) const {
  std::size_t count = 0;
  for (const PoseGraphEdge& edge : edges_) {
    count += edge.kind == kind ? 1 : 0;
  }
  return count;
}

double PoseGraph::chi2(PoseGraphMode mode) const {
  std::map<map::KeyframeId, Sim3> poses;
  for (const auto& [id, vertex] : vertices_) {
    poses.emplace(id, vertex.S_kf_world);
  }
  return chi2(mode, poses);
}

double PoseGraph::chi2(PoseGraphMode mode, const std::map<map::KeyframeId, Sim3>& poses) const {
  double sum = 0.0;
  for (const PoseGraphEdge& edge : edges_) {
    const Sim3& S_from = poses.at(edge.from);
    const Sim3& S_to = poses.at(edge.to);
    if (mode == PoseGraphMode::kSim3) {
      const Sim3::Tangent r = sim3EdgeResidual(edge.S_from_to, S_from, S_to);
      sum += r.dot(edge.information * r);
    } else {
      const SE3::Tangent r =
          se3EdgeResidual(dropScale(edge.S_from_to), S_from.toSE3(), S_to.toSE3());
      sum += r.dot(se3Information(edge.information) * r);
    }
  }
  return sum;
}

void PoseGraph::checkGauge() const {
  if (vertices_.empty()) {
    throw std::invalid_argument("pose graph: no vertices");
  }
  if (numFixed() == 0) {
    throw std::invalid_argument(
        "pose graph: no vertex is fixed, the gauge (pose and scale of "
        "the whole graph) would be free");
  }
  // Every vertex must reach a fixed one through edges, or its pose is undetermined.
  std::map<map::KeyframeId, std::vector<map::KeyframeId>> neighbours;
  for (const PoseGraphEdge& edge : edges_) {
    neighbours[edge.from].push_back(edge.to);
    neighbours[edge.to].push_back(edge.from);
  }
  std::set<map::KeyframeId> reached;
  std::deque<map::KeyframeId> queue;
  for (const auto& [id, vertex] : vertices_) {
    if (vertex.fixed) {
      reached.insert(id);
      queue.push_back(id);
    }
  }
  while (!queue.empty()) {
    const map::KeyframeId id = queue.front();
    queue.pop_front();
    for (const map::KeyframeId next : neighbours[id]) {
      if (reached.insert(next).second) {
        queue.push_back(next);
      }
    }
  }
  for (const auto& entry : vertices_) {
    if (!reached.count(entry.first)) {
      throw std::invalid_argument("pose graph: vertex " + std::to_string(entry.first) +
                                  " is not connected to a fixed vertex");
    }
  }
}

PoseGraphResult PoseGraph::optimize(const PoseGraphOptions& options) const {
  const common::Stopwatch timer;
  options.validate();
  checkGauge();
  const PoseGraphMode mode = options.mode;
  const int ambient = mode == PoseGraphMode::kSim3 ? Sim3::kNumParameters : SE3::kNumParameters;

  // Where LM starts: each loop's error spread along the odometry, or the given vertices.
  LoopErrorDistribution guess;
  if (options.loop_error_passes > 0) {
    guess = distributeLoopErrors(*this, mode, options.loop_error_passes);
  }
  // Parameter blocks in vertex order; the cost functions and the manifold outlive the problem.
  std::vector<double> parameters(vertices_.size() * ambient);
  std::map<map::KeyframeId, double*> block;
  std::size_t index = 0;
  for (const auto& [id, vertex] : vertices_) {
    double* data = parameters.data() + ambient * index;
    toParameters(mode, guess.S_kf_world.empty() ? vertex.S_kf_world : guess.S_kf_world[index],
                 data);
    block.emplace(id, data);
    ++index;
  }
  const std::unique_ptr<ceres::Manifold> manifold = makeVertexManifold(mode, options.jacobians);
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  costs.reserve(edges_.size());
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const auto& [id, vertex] : vertices_) {
    problem.AddParameterBlock(block.at(id), ambient, manifold.get());
    if (vertex.fixed) {
      problem.SetParameterBlockConstant(block.at(id));
    }
  }
  for (const PoseGraphEdge& edge : edges_) {
    costs.push_back(makeEdgeCost(mode, options.jacobians, edge.S_from_to, edge.information));
    problem.AddResidualBlock(costs.back().get(), nullptr, block.at(edge.from), block.at(edge.to));
  }

  ceres::Solver::Summary summary;
  ceres::Solve(solverOptions(options), &problem, &summary);
  if (options.log_progress) {
    std::printf("%s\n", summary.FullReport().c_str());
  }
  if (!summary.IsSolutionUsable() || !std::isfinite(summary.final_cost)) {
    throw std::runtime_error("pose graph: Ceres failed: " + summary.message);
  }

  PoseGraphResult result;
  for (const auto& [id, data] : block) {
    result.S_kf_world.emplace(id, fromParameters(mode, data));
  }
  // summary.iterations holds iteration 0 (the initial evaluation) too.
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.guess_loops = guess.loops;
  result.guess_chi2 = 2.0 * summary.initial_cost;  // Ceres minimises 0.5 |L^T r|^2
  result.initial_chi2 = options.loop_error_passes > 0 ? guess.given_chi2 : result.guess_chi2;
  result.final_chi2 = 2.0 * summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = ceres::TerminationTypeToString(summary.termination_type) +
                       std::string(": ") + summary.message;
  result.time_s = timer.seconds();
  return result;
}

Sim3::Tangent sim3EdgeResidual(const Sim3& S_ij, const Sim3& S_i, const Sim3& S_j) {
  return (S_ij * S_j * S_i.inverse()).log();
}

SE3::Tangent se3EdgeResidual(const SE3& T_ij, const SE3& T_i, const SE3& T_j) {
  return (T_ij * T_j * T_i.inverse()).log();
}

Sim3 similarityWithScale(const SE3& T, double scale) {
  if (!std::isfinite(scale) || !(scale > 0.0)) {
    throw std::invalid_argument("relative scale must be finite and > 0, got " +
                                std::to_string(scale));
  }
  return Sim3::fromScale(T.rotation(), T.translation(), scale);
}

SE3 dropScale(const Sim3& S) {
  return SE3(S.rotation(), S.translation());
}

Eigen::Vector3d cameraCentre(const Sim3& S_kf_world) {
  return -(S_kf_world.rotation().conjugate() * S_kf_world.translation()) / S_kf_world.scale();
}

}  // namespace scale_drift_slam::loop
