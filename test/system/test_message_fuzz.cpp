// Field-level fuzzing of the messages between the parts (system/message_validation.h): valid
// keyframes, map updates, loop constraints, relocalisation requests and answers are mutated by a
// seeded random MessageFieldMutator (numbers set to NaN, inf, huge, negative or zero; ids shifted;
// sizes blown up) and fed to the mapper, the loop closer and the tracker's inbox. Whatever
// arrives: no crash, nothing non-finite accepted, and a refused message leaves the map as it was.
// (Byte-level fuzzing of files is test/common/fuzz_mutator.h's, not this.)
// Cases per message kind: SDS_FUZZ_ITERATIONS (default 5000: about a second); `scripts/bench fuzz`
// runs a longer budget. Each run prints one "fuzz:" line with its figures.

#include <chrono>
#include <cstdlib>
#include <functional>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"

#include "scale_drift_slam/system/loop_closer_endpoint.h"
#include "scale_drift_slam/system/mapper_endpoint.h"
#include "scale_drift_slam/system/message_validation.h"
#include "scale_drift_slam/system/tracker_inbox.h"

namespace scale_drift_slam::system {
namespace {

int iterations() {
  const char* text = std::getenv("SDS_FUZZ_ITERATIONS");
  return text ? std::max(1, std::atoi(text)) : 5000;
}

std::uint64_t seed() {
  const char* text = std::getenv("SDS_FUZZ_SEED");
  return text ? std::strtoull(text, nullptr, 10) : 17;
}

/// Mutates the fields of a message: each call picks one of the numbers, ids or sizes registered
/// and breaks it.
class MessageFieldMutator {
 public:
  explicit MessageFieldMutator(std::uint64_t seed) : random_(seed) {}

  double hostileNumber(double valid) {
    static const double kValues[] = {std::numeric_limits<double>::quiet_NaN(),
                                     std::numeric_limits<double>::infinity(),
                                     -std::numeric_limits<double>::infinity(),
                                     1e300,
                                     -1e300,
                                     1e9,
                                     -1e7,
                                     0.0,
                                     -1.0,
                                     std::numeric_limits<double>::denorm_min()};
    std::uniform_int_distribution<int> pick(0, 11);
    const int k = pick(random_);
    if (k < 10) return kValues[k];
    return k == 10 ? -valid : valid * 1e12;
  }
  std::uint32_t hostileId(std::uint32_t valid) {
    std::uniform_int_distribution<int> pick(0, 4);
    switch (pick(random_)) {
      case 0:
        return std::numeric_limits<std::uint32_t>::max();
      case 1:
        return valid + 1 + std::uniform_int_distribution<std::uint32_t>(0, 5000)(random_);
      case 2:
        return valid - 1 - std::uniform_int_distribution<std::uint32_t>(0, 3)(random_);  // wraps
      case 3:
        return 0;
      default:
        return valid ^ (1u << std::uniform_int_distribution<int>(0, 31)(random_));
    }
  }
  std::size_t hostileSize() {
    std::uniform_int_distribution<int> pick(0, 3);
    switch (pick(random_)) {
      case 0:
        return 0;
      case 1:
        return std::uniform_int_distribution<std::size_t>(10001, 60000)(random_);
      default:
        return std::uniform_int_distribution<std::size_t>(1, 50)(random_);
    }
  }
  /// Applies 1 to 3 of `mutations` (each breaks one field).
  void mutate(const std::vector<std::function<void()>>& mutations) {
    const int count = std::uniform_int_distribution<int>(1, 3)(random_);
    std::uniform_int_distribution<std::size_t> pick(0, mutations.size() - 1);
    for (int i = 0; i < count; ++i)
      mutations[pick(random_)]();
  }
  std::mt19937_64& random() { return random_; }

 private:
  std::mt19937_64 random_;
};

bool finite(const geometry::SE3& T) {
  return T.rotation().coeffs().allFinite() && T.translation().allFinite();
}
bool finite(const geometry::Sim3& S) {
  return S.rotation().coeffs().allFinite() && S.translation().allFinite() &&
         std::isfinite(S.logScale());
}

bool finite(const map::KeyframeMessage& m) {
  bool ok = std::isfinite(m.keyframe.timestamp) && finite(m.keyframe.T_kf_world);
  for (const auto& o : m.keyframe.observations)
    ok = ok && o.xy.allFinite();
  for (const auto& o : m.earlier_observations)
    ok = ok && o.xy.allFinite();
  for (const auto& p : m.new_points)
    ok = ok && p.p_world.allFinite();
  return ok;
}
bool finite(const map::MapUpdate& u) {
  bool ok = !u.S_new_old || finite(*u.S_new_old);
  for (const auto& [id, T] : u.keyframe_poses)
    ok = ok && finite(T);
  for (const auto& [id, p] : u.point_positions)
    ok = ok && p.allFinite();
  for (const auto& [id, C] : u.keyframe_corrections)
    ok = ok && finite(C);
  return ok;
}
bool finite(const map::RelocalisationAnswer& a) {
  bool ok = std::isfinite(a.timestamp) && (!a.success || finite(a.T_cam_world));
  for (const auto& p : a.points)
    ok = ok && p.px.allFinite() && p.xy.allFinite();
  return ok;
}

/// Everything a message could change in a map, summed.
struct MapDigest {
  std::size_t keyframes = 0, points = 0;
  std::uint64_t version = 0;
  double sum = 0.0;
  bool finite = true;
  bool operator==(const MapDigest& o) const {
    return keyframes == o.keyframes && points == o.points && version == o.version && sum == o.sum;
  }
};

MapDigest digest(const map::Map& map) {
  MapDigest d{map.numKeyframes(), map.numPoints(), map.version(), 0.0, true};
  for (const auto& [id, keyframe] : map.keyframes()) {
    d.sum += keyframe.T_kf_world.translation().sum() + keyframe.T_kf_world.rotation().w() +
             static_cast<double>(keyframe.observations.size());
    d.finite = d.finite && finite(keyframe.T_kf_world);
  }
  for (const auto& [id, point] : map.points()) {
    d.sum += point.p_world.sum();
    d.finite = d.finite && point.p_world.allFinite();
  }
  return d;
}

map::KeyframeMessage validKeyframe(map::KeyframeId id) {
  map::KeyframeMessage message;
  message.keyframe.id = id;
  message.keyframe.timestamp = 0.1 * id;
  message.keyframe.T_kf_world =
      geometry::SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * id, Eigen::Vector3d::UnitY())),
                    Eigen::Vector3d(-0.1 * id, 0.0, 0.0));
  for (map::PointId k = 0; k < 4; ++k) {
    const map::PointId point = 4 * id + k;
    message.new_points.push_back({point, Eigen::Vector3d(0.1 * id, 0.2 * k, 2.0), id});
    message.keyframe.observations.push_back({point, Eigen::Vector2d(0.01 * k, 0.02)});
    if (id > 0) message.earlier_observations.push_back({id - 1, point, Eigen::Vector2d(0.0, 0.1)});
  }
  return message;
}

std::vector<std::function<void()>> keyframeMutations(map::KeyframeMessage& m,
                                                     MessageFieldMutator& f) {
  auto& kf = m.keyframe;
  return {
      [&] { kf.timestamp = f.hostileNumber(kf.timestamp); },
      [&] { kf.T_kf_world.translation()[f.random()() % 3] = f.hostileNumber(1.0); },
      [&] {
        Eigen::Quaterniond q = kf.T_kf_world.rotation();
        q.coeffs()[f.random()() % 4] = f.hostileNumber(1.0);
        kf.T_kf_world.setRotation(q);
      },
      [&] { kf.id = f.hostileId(kf.id); },
      [&] {
        kf.observations.resize(f.hostileSize(), {4 * kf.id, Eigen::Vector2d(0.0, 0.1)});
      },
      [&] {
        if (!kf.observations.empty())
          kf.observations.back().xy[f.random()() % 2] = f.hostileNumber(0.1);
      },
      [&] {
        if (!kf.observations.empty())
          kf.observations.front().point_id = f.hostileId(kf.observations.front().point_id);
      },
      [&] {
        m.new_points.resize(f.hostileSize(), {4 * kf.id, Eigen::Vector3d(0.0, 0.0, 1.0), 0});
      },
      [&] {
        if (!m.new_points.empty())
          m.new_points.back().p_world[f.random()() % 3] = f.hostileNumber(2.0);
      },
      [&] {
        if (!m.new_points.empty()) m.new_points.front().id = f.hostileId(m.new_points.front().id);
      },
      [&] {
        if (!m.new_points.empty()) m.new_points.front().reference_keyframe = f.hostileId(kf.id);
      },
      [&] {
        m.earlier_observations.resize(f.hostileSize(), {0, 4 * kf.id, {0.0, 0.0}});
      },
      [&] {
        if (m.earlier_observations.empty()) return;
        m.earlier_observations.front().keyframe_id = f.hostileId(kf.id);
        m.earlier_observations.back().xy[f.random()() % 2] = f.hostileNumber(0.1);
      },
  };
}

map::MapUpdate validUpdate(std::uint64_t version, map::KeyframeId newest) {
  map::MapUpdate update;
  update.map_version = version;
  for (map::KeyframeId id = 1; id <= newest; ++id)
    update.keyframe_poses.emplace_back(id, validKeyframe(id).keyframe.T_kf_world);
  update.point_positions.emplace_back(4 * newest, Eigen::Vector3d(0.1, 0.0, 2.0));
  return update;
}

std::vector<std::function<void()>> updateMutations(map::MapUpdate& u, MessageFieldMutator& f) {
  return {
      [&] {
        u.S_new_old = geometry::Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
                                     f.hostileNumber(0.1));
      },
      [&] {
        u.S_new_old = geometry::Sim3::fromScale(Eigen::Quaterniond::Identity(),
                                                Eigen::Vector3d::Zero(), f.hostileNumber(1.0));
      },
      [&] {
        if (!u.keyframe_poses.empty())
          u.keyframe_poses.back().second.translation()[1] = f.hostileNumber(0.5);
      },
      [&] {
        if (!u.keyframe_poses.empty())
          u.keyframe_poses.front().first = f.hostileId(u.keyframe_poses.front().first);
      },
      [&] {
        u.keyframe_poses.resize(f.hostileSize(), {1, geometry::SE3()});
      },
      [&] {
        if (!u.point_positions.empty())
          u.point_positions.front().second[f.random()() % 3] = f.hostileNumber(2.0);
      },
      [&] {
        u.point_positions.resize(f.hostileSize(), {1, Eigen::Vector3d(0.0, 0.0, 1.0)});
      },
      [&] {
        u.keyframe_corrections.emplace_back(
            f.hostileId(1), geometry::Sim3(Eigen::Quaterniond::Identity(),
                                           Eigen::Vector3d(f.hostileNumber(0.1), 0.0, 0.0), 0.0));
      },
      [&] { u.loop_links.emplace_back(f.hostileId(0), f.hostileId(1)); },
      [&] { u.removed_points.assign(f.hostileSize(), f.hostileId(3)); },
      [&] { u.culled_keyframes.assign(f.hostileSize(), f.hostileId(2)); },
  };
}

struct Figures {
  int cases = 0, refused = 0;
};

class MessageFuzz : public ::testing::Test {
 protected:
  void SetUp() override { restart(); }
  void restart() {
    mapping::MapperParams params;
    params.run_window_ba = false;  // the validation, not the BA, is under test
    mapper = std::make_unique<MapperEndpoint>(params, 7);
    closer = std::make_unique<LoopCloserEndpoint>(loop::LoopCloserParams{});
    for (map::KeyframeId id = 0; id < 5; ++id) {
      ASSERT_TRUE(mapper->addKeyframe({1, 0, 0}, validKeyframe(id), [] { return 500.0; }).added);
      ASSERT_TRUE(closer->addKeyframe({1, 0, 0}, validKeyframe(id), camera).added);
    }
    next_id = 5;
  }
  static std::shared_ptr<const geometry::CameraModel> camera() {
    return test::pinholeCamera(500.0);
  }
  static void report(const char* kind, const Figures& figures,
                     std::chrono::steady_clock::time_point start) {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("fuzz: %s: %d cases, %d refused, %d accepted, %.2f s, %.0f cases/s\n", kind,
                figures.cases, figures.refused, figures.cases - figures.refused, s,
                figures.cases / std::max(s, 1e-9));
  }

  std::unique_ptr<MapperEndpoint> mapper;
  std::unique_ptr<LoopCloserEndpoint> closer;
  map::KeyframeId next_id = 5;
  MessageFieldMutator mutator{seed()};
};

TEST_F(MessageFuzz, MutatedKeyframes) {
  const auto start = std::chrono::steady_clock::now();
  Figures figures;
  for (int i = 0; i < iterations(); ++i) {
    if (mapper->map().numKeyframes() > 200) restart();
    map::KeyframeMessage message = validKeyframe(next_id);
    mutator.mutate(keyframeMutations(message, mutator));
    const MapDigest before = digest(mapper->map());
    const std::size_t closer_before = closer->closer()->numKeyframes();
    const auto at_mapper = mapper->addKeyframe({1, 0, 0}, message, [] { return 500.0; });
    const auto at_closer = closer->addKeyframe({1, 0, 0}, message, camera);
    ++figures.cases;
    ASSERT_EQ(at_mapper.added, at_closer.added) << at_mapper.refusal << " | " << at_closer.refusal;
    if (!at_mapper.added) {
      ++figures.refused;
      ASSERT_FALSE(at_mapper.refusal.empty());
      ASSERT_EQ(digest(mapper->map()), before) << "case " << i << ": " << at_mapper.refusal;
      ASSERT_EQ(closer->closer()->numKeyframes(), closer_before) << "case " << i;
      continue;
    }
    ASSERT_TRUE(finite(message)) << "case " << i << ": a non-finite keyframe was accepted";
    ASSERT_LE(message.keyframe.observations.size(), 10000u);
    ASSERT_TRUE(digest(mapper->map()).finite) << "case " << i;
    next_id = std::max(next_id, message.keyframe.id + 1);
  }
  report("keyframes", figures, start);
  EXPECT_GT(figures.refused, figures.cases / 2);  // most mutations break the message
  EXPECT_LT(figures.refused, figures.cases);      // some leave it valid (e.g. an id 0 bit flip)
}

TEST_F(MessageFuzz, MutatedMapUpdates) {
  const auto start = std::chrono::steady_clock::now();
  Figures figures;
  tracking::Tracker tracker(camera(), tracking::TrackerParams{});
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  inbox.startSession(1);
  std::uint64_t version = 1;
  for (int i = 0; i < iterations(); ++i) {
    map::MapUpdate update = validUpdate(version, 4);
    mutator.mutate(updateMutations(update, mutator));
    const MapDigest before = digest(closer->closer()->map());
    const auto outcome = closer->applyMapUpdate({1, 7, version}, update);
    ++figures.cases;
    if (!outcome.applied) {
      ++figures.refused;
      ASSERT_FALSE(outcome.refusal.empty()) << "case " << i;
      ASSERT_EQ(digest(closer->closer()->map()), before) << "case " << i << ": " << outcome.refusal;
    } else {
      ASSERT_TRUE(finite(update)) << "case " << i << ": a non-finite update was applied";
      ASSERT_TRUE(digest(closer->closer()->map()).finite) << "case " << i;
      ++version;
    }
    // The tracker made no keyframe: only an update naming none may reach it.
    const std::uint64_t tracker_version = tracker.trackingMap().version();
    inbox.push(Addressed<map::MapUpdate>{{1, 7, version + 1000}, update});
    const TrackerInbox::Report report = inbox.drain(tracker, trajectory);
    const bool names_keyframes = !update.keyframe_poses.empty() ||
                                 !update.keyframe_corrections.empty() || !update.loop_links.empty();
    if (names_keyframes || !finite(update)) {
      ASSERT_EQ(report.refused.size(), 1u) << "case " << i;
      ASSERT_EQ(tracker.trackingMap().version(), tracker_version) << "case " << i;
    }
  }
  report("map updates", figures, start);
  EXPECT_GT(figures.refused, figures.cases / 3);
}

TEST_F(MessageFuzz, MutatedLoopConstraints) {
  const auto start = std::chrono::steady_clock::now();
  Figures figures;
  int applied = 0;
  for (int i = 0; i < iterations(); ++i) {
    loop::LoopConstraint c;
    c.current_id = 4;
    c.loop_id = 0;
    c.scale = 1.0;
    c.S_current_loop = geometry::Sim3::fromScale(Eigen::Quaterniond::Identity(),
                                                 Eigen::Vector3d(0.4, 0.0, 0.0), 1.0);
    c.T_current_loop = c.S_current_loop.toSE3();
    mutator.mutate({
        [&] { c.current_id = mutator.hostileId(c.current_id); },
        [&] { c.loop_id = mutator.hostileId(c.loop_id); },
        [&] { c.scale = mutator.hostileNumber(1.0); },
        [&] {
          c.S_current_loop = geometry::Sim3::fromScale(
              Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), mutator.hostileNumber(1.0));
        },
        [&] {
          Eigen::Vector3d t = c.S_current_loop.translation();
          t[2] = mutator.hostileNumber(0.4);
          c.S_current_loop = geometry::Sim3(c.S_current_loop.rotation(), t, 0.0);
        },
        [&] { c.T_current_loop.translation()[0] = mutator.hostileNumber(0.4); },
        [&] { c.rmse_px = mutator.hostileNumber(1.0); },
        [&] { c.num_inliers = -static_cast<int>(mutator.hostileSize()) - 1; },
    });
    ++figures.cases;
    const std::string problem = loopConstraintProblem(c, MessageLimits{});
    if (problem.empty()) {
      // Valid content: the graph runs when both keyframes are in the map; the map stays finite.
      ASSERT_TRUE(finite(c.S_current_loop) && finite(c.T_current_loop) && std::isfinite(c.scale) &&
                  std::isfinite(c.rmse_px))
          << "case " << i;
      if (mapper->loopEdges().size() >= 20) restart();  // a small graph: thousands of cases
      const auto outcome = mapper->closeLoop({1, 7, 3}, c);
      ASSERT_TRUE(outcome.refusal.empty()) << outcome.refusal;
      ASSERT_TRUE(digest(mapper->map()).finite) << "case " << i;
      applied += outcome.statistics.applied;
      continue;
    }
    ++figures.refused;
    const MapDigest before = digest(mapper->map());
    const auto outcome = mapper->closeLoop({1, 7, 3}, c);
    ASSERT_EQ(outcome.refusal, problem);
    ASSERT_FALSE(outcome.update.has_value());
    ASSERT_EQ(digest(mapper->map()), before) << "case " << i;
  }
  report("loop constraints", figures, start);
  std::printf("fuzz: loop constraints: %d applied by the mapper\n", applied);
  EXPECT_GT(applied, 0);
  EXPECT_GT(figures.refused, figures.cases / 2);
}

TEST_F(MessageFuzz, MutatedRelocalisationRequestsAndAnswers) {
  const auto start = std::chrono::steady_clock::now();
  Figures figures;
  tracking::Tracker tracker(camera(), tracking::TrackerParams{});
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  inbox.startSession(1);
  for (int i = 0; i < iterations(); ++i) {
    map::RelocalisationAnswer a;
    a.frame_index = 40;
    a.timestamp = 4.0;
    a.success = true;
    a.keyframe_id = 0;
    a.inliers = 30;
    a.points.push_back({3, Eigen::Vector2d(100.0, 120.0), Eigen::Vector2d(0.1, -0.2)});
    mutator.mutate({
        [&] { a.timestamp = mutator.hostileNumber(4.0); },
        [&] { a.T_cam_world.translation()[0] = mutator.hostileNumber(0.1); },
        [&] { a.keyframe_id = mutator.hostileId(0); },
        [&] { a.points.resize(mutator.hostileSize(), a.points.front()); },
        [&] {
          if (!a.points.empty()) a.points.front().px[1] = mutator.hostileNumber(120.0);
        },
        [&] {
          if (!a.points.empty()) a.points.front().xy[0] = mutator.hostileNumber(0.1);
        },
        [&] { a.inliers = -1; },
        [&] { a.success = false; },
    });
    ++figures.cases;
    inbox.push(Addressed<map::RelocalisationAnswer>{{1, 7, 1}, a});
    const TrackerInbox::Report report = inbox.drain(tracker, trajectory);
    ASSERT_FALSE(report.relocalised.has_value()) << "case " << i;  // it asked nothing
    if (!finite(a)) ASSERT_EQ(report.refused.size(), 1u) << "case " << i;
    figures.refused += static_cast<int>(report.refused.size());

    map::RelocalisationRequest r;
    r.frame_index = 41;
    r.timestamp = 4.1;
    r.image = cv::Mat(24, 32, CV_8UC1, cv::Scalar(60));
    mutator.mutate({
        [&] { r.timestamp = mutator.hostileNumber(4.1); },
        [&] { r.image = cv::Mat(); },
        [&] { r.image = cv::Mat(1, 20000, CV_8UC1, cv::Scalar(1)); },
    });
    const auto answer = closer->relocalise({1, 0, 0}, r);
    ++figures.cases;
    if (!std::isfinite(r.timestamp) || r.image.empty() || r.image.cols > 16384) {
      ++figures.refused;
      ASSERT_FALSE(answer.message.success) << "case " << i;
      ASSERT_FALSE(answer.message.reason.empty()) << "case " << i;
    }
  }
  report("relocalisation messages", figures, start);
  EXPECT_GT(figures.refused, 0);
}

}  // namespace
}  // namespace scale_drift_slam::system
