#pragma once
// The front-end (doc/algorithm.md, "Front-end"): turns frames into camera poses and keyframes.
// Per frame: grey conversion and pyramid, then either map initialisation (MapInitializer) or
// tracking: motion prior from optical flow, active search for the local map points, motion-only
// BA with the pseudo-Huber kernel, a quality verdict (good / weak / lost), the inverse-depth
// filters of the new features, and the keyframe rule. Keyframes leave as map::KeyframeMessage;
// corrections come back as map::MapUpdate (applyMapUpdate), applied between frames.
// Runs on one thread (the tracking thread or node); owns its TrackingMap copy and never blocks.

#include <future>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/tracking/feature_candidates.h"
#include "scale_drift_slam/tracking/keyframe_rule.h"
#include "scale_drift_slam/tracking/keyframe_triangulation.h"
#include "scale_drift_slam/tracking/map_initializer.h"
#include "scale_drift_slam/tracking/motion_prior.h"
#include "scale_drift_slam/tracking/tracking_map.h"

namespace scale_drift_slam::tracking {

struct TrackerParams {
  int pyramid_levels = 4;
  double min_contrast = 3.0;  ///< Frames with a smaller grey-level std (after the
                              ///< contrast stretch) are unusable.
  /// Frames whose 1st-99th percentile grey range is below this are stretched towards it...
  double contrast_target_range = 128.0;
  double max_contrast_gain = 4.0;  ///< ...by at most this gain (1: never stretched).
  /// Bits used by 16-bit (mono16) images (8..16): a 12-bit camera's frames scaled by 1/16 would
  /// use 1/16 of the grey range. 0: the bits of the largest value seen so far.
  int mono16_bit_depth = 0;
  int good_inliers = 50;            ///< Inliers for "good" tracking (fewer: weak).
  int min_inliers = 15;             ///< Below: lost.
  int local_recent_keyframes = 6;   ///< Local map: points of the newest keyframes...
  int local_nearest_keyframes = 6;  ///< ...and of the keyframes closest to the camera among
                                    ///< the co-visibility neighbourhood of the tracked region,
  int local_covisibility_min_shared = 5;  ///< ...keyframes sharing this many points being linked.
  int retire_after_searches = 10;         ///< Points searched this often...
  double retire_found_ratio = 0.3;        ///< ...and found less than this share are not searched.
  int max_rejected_frames = 3;            ///< This many unusable frames in a row: lost.
  /// While lost, a relocalisation request not answered within this many frames is sent again.
  int relocalisation_retry_frames = 30;
  /// Lost this many frames in a row with a map of fewer than `restart_below_keyframes`
  /// keyframes (too young for place recognition to relocalise in): the tracker initialises a
  /// new map from the frames that follow, and once it starts the young map is discarded
  /// (FrameResult::map_restarted). Until then the young map is kept, still lost, and may
  /// relocalise; if no new map starts it stays the map. 0 keyframes: never.
  int restart_after_lost_frames = 15;
  int restart_below_keyframes = 30;
  /// A frame tracked with fewer than good_inliers (the flow could not carry it: a wide baseline
  /// between frames) is tracked again from the newest keyframe's map points matched by ORB
  /// descriptor (PnP RANSAC, then active search around that pose), else from the previous
  /// frame's inliers; kept when it has more inliers.
  bool recover_from_keyframe = true;
  /// The recovery's descriptor matching: largest Hamming distance (of 256 bits) and best /
  /// second-best distance ratio. Looser matching (80, 0.9) gave TUM fr3 at 1 Hz two more frames
  /// with a 15 px flow window and none with 11, and let office_orbit at 0.6 Hz accept a pose on
  /// 18 inliers that spoilt the map (doc/benchmarks.md, "Recovery from the previous frame").
  int recovery_max_descriptor_distance = 50;
  double recovery_max_ratio = 0.8;
  /// ...and so is a frame whose share of inliers among the points found falls below this
  /// fraction of its recent average (a pose from a wrong prior, points matched onto the wrong
  /// texture; the share itself differs between cameras: ~0.95 on renders, 0.5-0.7 on real
  /// images). 0: never.
  double recover_on_inlier_share_drop = 0.6;
  /// ...and so is a frame left with fewer inliers than this fraction of the previous frame's: a
  /// pose that kept a third of its support may rest on a wrong prior's matches (office_orbit at
  /// 1 Hz: 54 of 88 found agreed on a pose 0.2 m off, after 152 inliers the frame before; the
  /// recovery found 149), or the view moved on a long way. The recovery is kept only when it
  /// finds more inliers. 0: never.
  double recover_on_inlier_drop = 0.5;
  /// A keyframe also carries the matches its frame's pose refused within this many pixels of the
  /// point's projection (0: none). A map point with a wrong depth is matched again and again on
  /// the right texture and refused by every pose as its reprojection walks away; without an
  /// observation no window BA ever sees that it is wrong (doc/benchmarks.md, "Where real images'
  /// outliers come from"). With these, the BA (robust kernel) moves it. They also count among the
  /// keyframe's tracked points, so keyframes come sooner where many matches are refused, and
  /// that is most of their gain on real images. With a 5 s outage of the link between the
  /// tracker and the mapper (test twohosts_outage) they lost tracking or the scale in 7 of 22
  /// runs, until the tracker's newer keyframes rode with the mapper's corrections
  /// (TrackingMap::tailCorrection): then 15 of 15 passed (doc/benchmarks.md, "Refused matches
  /// and a link outage: a second look").
  double keyframe_refused_matches_px = 10.0;
  /// Patches of map points not searched for this many frames are kept compressed, 4 bits per
  /// pixel (features::PointAppearance::compress; expanded when searched again). 0: never.
  int compress_idle_patches_after_frames = 100;
  /// A keyframe's new points by ORB matching with the earlier keyframes (keyframe_triangulation.h,
  /// about half of a keyframe frame's CPU) are found by a worker thread while the camera's next
  /// frame is awaited; the keyframe is finished (its points added, new feature candidates
  /// spawned) and reported when the next frame comes, before anything else changes the tracker,
  /// or by finishKeyframes(). Every result is the same as without the worker; only the keyframe
  /// is reported one frame later. false: all in the keyframe's frame (deterministic timing; the
  /// SLAM system turns it off when it runs inline).
  bool keyframe_worker = true;
  features::FeatureDetectionParams features;
  InitializerParams initializer;
  MotionPriorParams motion_prior;
  features::ActiveSearchParams search;
  features::MotionOnlyBundleAdjustmentParams motion_ba;
  FeatureCandidateParams candidates;
  KeyframeRuleParams keyframes;
  KeyframeTriangulationParams triangulation;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

enum class TrackingState { kInitializing, kGood, kWeak, kLost };
std::string trackingStateName(TrackingState state);

/// Milliseconds spent in each stage of one frame (0 when the stage did not run). `keyframe`: the
/// keyframe rule, making a keyframe, and finishing the one the worker had (keyframe_worker).
/// `cpu` is the tracking thread's CPU time for the whole frame (unaffected by other processes).
struct StageTimes {
  double prepare = 0, flow = 0, search = 0, motion_ba = 0, filters = 0, keyframe = 0, total = 0;
  double cpu = 0;
  /// The keyframe worker's CPU time for the keyframes reported with this frame (not in `cpu`;
  /// 0 without tracker.keyframe_worker, where that work is part of `cpu`).
  double keyframe_worker_cpu = 0;
};

struct FrameResult {
  double timestamp = 0.0;
  TrackingState state = TrackingState::kInitializing;
  bool rejected = false;  ///< The frame itself was unusable (see message).
  bool has_pose = false;  ///< T_cam_world is an estimate for this frame.
  geometry::SE3 T_cam_world;
  /// J^T J of the motion-only BA's inliers (features::MotionOnlyResult::inlier_information):
  /// features::poseCovariance of it is T_cam_world's covariance. Zero when the pose did not
  /// come from the motion-only BA (map initialisation).
  Eigen::Matrix<double, 6, 6> pose_information = Eigen::Matrix<double, 6, 6>::Zero();
  int num_visible = 0, num_found = 0, num_inliers = 0;
  std::vector<Eigen::Vector2d> tracked_px;  ///< Image positions of the inlier map points.
  /// Keyframes finished at this frame (2 at initialisation). With tracker.keyframe_worker a
  /// keyframe dropped at one frame is finished at the next (or by Tracker::finishKeyframes()).
  std::vector<map::KeyframeMessage> keyframes;
  /// The newest keyframe when the frame was tracked: the frame's pose moves with its loop
  /// corrections (mapping::CorrectedTrajectory).
  std::optional<map::KeyframeId> reference_keyframe;
  /// Loop corrections applied since the previous frame: world points moved by p_new = S p_old.
  std::optional<geometry::Sim3> loop_correction;
  /// Lost: where is this frame? (for the loop closer; at most one request outstanding).
  std::optional<map::RelocalisationRequest> relocalisation_request;
  bool relocalised = false;  ///< Tracking resumed at this frame from a relocalisation answer.
  /// The young map was discarded at this frame: initialising again; keyframe and point ids start
  /// from 0 again, the receivers of the earlier keyframes must drop them.
  bool map_restarted = false;
  StageTimes times;
  std::string message;
};

class Tracker {
 public:
  Tracker(std::shared_ptr<const geometry::CameraModel> camera, const TrackerParams& params);

  /// Processes one frame. Never throws for a bad frame (black, blank, wrong size, wrong
  /// encoding): the result says it was rejected and why.
  FrameResult processFrame(double timestamp, const cv::Mat& image,
                           features::PixelEncoding encoding);
  /// Applies a mapper correction to the local map (call between frames).
  void applyMapUpdate(const map::MapUpdate& update);
  /// Takes the loop closer's answer to the last relocalisation request (call between frames).
  /// Returns true when it was used: the next frame is tracked from the relocalised frame, its
  /// pose and the map points found in it. Stale, failed or unneeded answers are ignored.
  bool applyRelocalisation(const map::RelocalisationAnswer& answer);

  /// Starts from a saved map (call before the first frame): its keyframes and the points that
  /// have an appearance, the co-visibility from the observations, the loop links. The tracker is
  /// then lost in it: it asks for relocalisation with every frame until an answer comes (it does
  /// not track from a guessed pose), never initialises a new map and never discards this one.
  /// New keyframe and point ids continue above the map's.
  void restoreMap(const map::Map& map,
                  const std::unordered_map<map::PointId, features::PointAppearance>& appearances,
                  const std::vector<std::pair<map::KeyframeId, map::KeyframeId>>& loop_links);
  /// Localisation only: no keyframe is made (the map is not changed); tracking, relocalisation
  /// and map updates work as before.
  void setLocalizationOnly(bool on) { localization_only_ = on; }
  bool localizationOnly() const { return localization_only_; }

  /// A keyframe dropped but not yet finished (tracker.keyframe_worker).
  bool keyframePending() const { return pending_keyframe_.has_value(); }
  /// Its worker is done: finishKeyframes() would not wait.
  bool keyframeReady() const;
  /// Finishes the pending keyframe (waiting for its worker) and returns the keyframes finished
  /// and not yet reported: at the end of a stream, or to report a keyframe before the next frame.
  std::vector<map::KeyframeMessage> finishKeyframes();

  TrackingState state() const { return state_; }
  /// The bit depth 16-bit frames are read with (tracker.mono16_bit_depth, or measured); 0 before
  /// the first 16-bit frame.
  int mono16BitDepth() const { return mono16_bits_; }
  /// The log line for a new mono16BitDepth(): how 16-bit frames are scaled and where it came from.
  std::string describeMono16BitDepth() const;
  const TrackingMap& trackingMap() const { return map_; }
  std::size_t numCandidates() const { return candidates_.size(); }

 private:
  struct Measurement {  ///< A map point found in the last frame (seed of the next flow).
    map::PointId id;
    Eigen::Vector2d px;
    Eigen::Vector2d xy;
  };

  void initialise(double timestamp, const features::ImagePyramid& image, FrameResult* result);
  /// Builds the map from the initializer's two views (the frame's pose and both keyframes go
  /// into `result`).
  void startMap(const InitialMap& initial, double timestamp, const features::ImagePyramid& image,
                FrameResult* result);
  void track(double timestamp, const features::ImagePyramid& image, FrameResult* result);
  MotionPrior estimatePrior(const features::ImagePyramid& image,
                            std::vector<cv::Point2f>* candidate_px,
                            std::vector<unsigned char>* candidate_ok);
  /// The local map's points (ids and what active search needs) around the prior.
  std::vector<features::SearchPoint> localSearchPoints(const MotionPrior& prior,
                                                       std::vector<map::PointId>* ids);
  /// Searches the points searched but not found again around the solved pose; keeps the new
  /// matches and pose when they give more inliers.
  void researchMissed(const geometry::SE3& T_cam_world, const std::vector<map::PointId>& ids,
                      const std::vector<features::SearchPoint>& search_points,
                      const features::ImagePyramid& image, const features::CornerGrid& corners,
                      std::vector<features::SearchMatch>* matches,
                      std::vector<Measurement>* inliers, geometry::SE3* T_solved,
                      FrameResult* result);
  /// The points' search statistics (retirement) and the visible count of `result`.
  /// The newest keyframe's map points and image, for recoverFromKeyframe...
  void rememberKeyframePoints(const map::KeyframeMessage& message,
                              const features::ImagePyramid& image);
  /// ...described (ORB) the first time a frame needs them (most keyframes never do).
  void describeKeyframePoints();
  struct DescribedPoints;
  /// ORB descriptors of the points' corners, from their image (released then); corners whose
  /// patch leaves the image are dropped with their ids.
  static void describePoints(DescribedPoints* points);
  /// The previous frame's inliers, described in its image.
  DescribedPoints previousFramePoints() const;
  /// Corners of the frame being recovered, described once for every attempt.
  struct FrameCorners {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
  };
  /// The pose from `points` matched by descriptor in the frame (PnP RANSAC, refined by the
  /// motion-only BA); nothing when too few match.
  std::optional<geometry::SE3> poseFromDescribedPoints(const DescribedPoints& points,
                                                       const FrameCorners& frame);
  /// Recovery of a frame the prior failed: a pose from the newest keyframe's points, else from
  /// the previous frame's inliers (tryPoseFrom each).
  void recoverFromKeyframe(const features::ImagePyramid& image, const features::CornerGrid& corners,
                           const std::vector<map::PointId>& ids,
                           const std::vector<features::SearchPoint>& search_points,
                           std::vector<features::SearchMatch>* matches,
                           std::vector<Measurement>* inliers, geometry::SE3* T_solved,
                           FrameResult* result);
  /// Active search around a recovered pose; keeps the new matches and pose (true) when they give
  /// more inliers than the frame has.
  bool tryPoseFrom(const std::optional<geometry::SE3>& T_pnp, const features::ImagePyramid& image,
                   const features::CornerGrid& corners, const std::vector<map::PointId>& ids,
                   const std::vector<features::SearchPoint>& search_points,
                   std::vector<features::SearchMatch>* matches, std::vector<Measurement>* inliers,
                   geometry::SE3* T_solved, FrameResult* result);
  void recordSearches(const std::vector<map::PointId>& ids,
                      const std::vector<features::SearchMatch>& matches, FrameResult* result);
  /// Motion-only BA on the found matches from `T_guess`; fills the inliers and the found and
  /// inlier counts of `result`.
  geometry::SE3 solvePose(const geometry::SE3& T_guess, const std::vector<map::PointId>& ids,
                          const std::vector<features::SearchMatch>& matches,
                          std::vector<Measurement>* inliers, FrameResult* result);
  /// The matches the pose refused within keyframe_refused_matches_px of their projection.
  std::vector<Measurement> refusedMatches(const geometry::SE3& T_cam_world,
                                          const std::vector<map::PointId>& ids,
                                          const std::vector<features::SearchMatch>& matches,
                                          const std::vector<Measurement>& inliers) const;
  void dropKeyframe(double timestamp, const features::ImagePyramid& image,
                    const std::vector<Measurement>& inliers,
                    const std::vector<Measurement>& refused, FrameResult* result);
  /// A new map point in the tracking map, announced in `message` (new_points); returns its id.
  map::PointId addNewPoint(const Eigen::Vector3d& p_world, map::KeyframeId reference_keyframe,
                           features::PointAppearance appearance, map::KeyframeMessage* message);
  struct WorkerOutput {
    std::vector<TriangulatedPoint> points;
    double cpu_ms = 0.0;  ///< The worker thread's CPU time (0 when run in the frame).
  };
  /// A keyframe whose triangulation runs in the worker (tracker.keyframe_worker).
  struct PendingKeyframe {
    map::KeyframeMessage message;
    features::ImagePyramid image;
    std::vector<Eigen::Vector2d> occupied;  ///< Pixels of its points so far.
    std::future<WorkerOutput> triangulated;
  };
  /// Triangulates the keyframe's new points in the worker (finished later), or at once (the
  /// keyframe is finished into `result`).
  void triangulateKeyframe(PendingKeyframe pending, bool in_worker, FrameResult* result);
  /// Adds the triangulated points, spawns new candidates, reports the keyframe.
  void completeKeyframe(PendingKeyframe pending, std::vector<map::KeyframeMessage>* out);
  /// Completes the pending keyframe into finished_keyframes_ (before anything changes the map).
  void finishPendingKeyframe();
  map::KeyframeMessage makeKeyframe(double timestamp, const geometry::SE3& T_kf_world,
                                    const features::ImagePyramid& image);
  double sceneDepth(const geometry::SE3& T_cam_world) const;
  void rejectFrame(const std::string& reason, FrameResult* result);
  void requestRelocalisation(double timestamp, const features::ImagePyramid& image,
                             FrameResult* result);
  /// Counts the frames lost in a row; a young map lost too long starts the initialisation of
  /// a new map beside it (TrackerParams::restart_after_lost_frames).
  void startNextMapAfterYoungMapLost(FrameResult* result);
  /// Feeds the frame to the initialisation of the next map; when that map starts, the lost
  /// young map is discarded.
  void initialiseNextMap(double timestamp, const features::ImagePyramid& image,
                         FrameResult* result);

  std::shared_ptr<const geometry::CameraModel> camera_;
  /// The camera that measures the frame being tracked: camera_, or with a rolling shutter
  /// camera_ moving as the frame's motion says (geometry/rolling_shutter_camera.h).
  std::shared_ptr<const geometry::CameraModel> frame_camera_;
  TrackerParams params_;
  double focal_;
  double field_of_view_;  ///< The narrowest angular extent of the image (rad), for keyframes.
  MapInitializer initializer_;
  MotionPriorEstimator motion_prior_;
  FeatureCandidates candidates_;
  KeyframeTriangulation triangulation_;
  struct DescribedPoints {          ///< Map points seen in one image and their ORB descriptors.
    std::uint64_t frame_index = 0;  ///< Of the image.
    std::vector<map::PointId> ids;
    std::vector<cv::KeyPoint> corners;  ///< Their measured pixels, until described.
    cv::Mat image;                      ///< The keyframe's image, until described.
    bool described = false;
    cv::Mat descriptors;
  };
  DescribedPoints keyframe_points_;  ///< The newest keyframe's.
  TrackingMap map_;
  TrackingState state_ = TrackingState::kInitializing;

  features::ImagePyramid previous_image_;
  double previous_timestamp_ = 0.0;  ///< Of previous_image_.
  geometry::SE3 T_previous_world_, T_before_previous_world_;
  std::vector<Measurement> previous_measurements_;
  double last_scene_depth_ = 1.0;
  std::uint64_t frame_index_ = 0;
  std::uint64_t last_patch_sweep_frame_ = 0;  ///< compress_idle_patches_after_frames
  map::KeyframeId next_keyframe_id_ = 0;
  map::PointId next_point_id_ = 0;
  int rejected_in_row_ = 0;
  int mono16_bits_ = 0;
  int lost_in_row_ = 0;
  /// A young map lost too long: the frames also go to the initializer, for the next map.
  bool initialising_next_map_ = false;
  int tracked_at_keyframe_ = 0;  ///< Map points seen in the last keyframe (keyframe rule).
  /// Moving average (weight 0.2) of the tracked frames' share of inliers among the points found
  /// (recover_on_inlier_share_drop); 0 until a frame is tracked.
  double inlier_share_average_ = 0.0;
  std::optional<geometry::Sim3> pending_loop_correction_;  ///< Reported with the next frame.
  std::uint64_t last_loop_version_ = 0;  ///< Map version of the last loop correction applied.
  struct PendingRelocalisation {
    std::uint64_t frame_index = 0;
    /// The requested frame, then every frame tracked (in vain) since: the answer's points are
    /// carried through them by flow.
    std::vector<features::ImagePyramid> frames;
  };
  std::optional<PendingRelocalisation> relocalisation_;  ///< The request outstanding.
  bool resume_from_relocalisation_ = false;
  bool localization_only_ = false;
  /// A restored map: not yet relocalised in (no pose to track from), never discarded.
  bool awaiting_first_relocalisation_ = false;
  bool restored_map_ = false;
  double worker_cpu_ms_ = 0.0;    ///< Of the keyframes finished since the last frame's result.
  std::string keyframe_problem_;  ///< Why a keyframe got no matched points (the next message).
  /// Keyframes finished between frames (by a map update), reported with the next frame.
  std::vector<map::KeyframeMessage> finished_keyframes_;
  /// The keyframe whose worker may be running. Last member: destroyed first, its future waits
  /// for the worker, which uses triangulation_.
  std::optional<PendingKeyframe> pending_keyframe_;
};

}  // namespace scale_drift_slam::tracking
