#pragma once
// Place recognition by appearance (doc/algorithm.md, "Loop closure detection"): a bag of
// binary words over the keyframes' ORB descriptors, an inverted index with tf-idf L1 scores
// normalised by the score against the previous keyframe, islands of neighbouring keyframes,
// a geometric check against repeated texture, and consistency over a streak of queries
// (doc/place_recognition.md). Loop verification (loop constraint, Sim(3)) comes after it.

#include <deque>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/bow_database.h"
#include "scale_drift_slam/loop/geometric_check.h"
#include "scale_drift_slam/loop/place_recognition_params.h"
#include "scale_drift_slam/loop/vocabulary.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::loop {

enum class CandidateStatus {
  kAccepted,          ///< Verified and consistent: a loop to verify metrically.
  kFailedGeometry,    ///< The geometric check failed (see geometry.reason).
  kNotYetConsistent,  ///< Verified, but not yet over min_consistent_queries queries.
  kContinuesLoop,     ///< Verified, but only continues a loop already accepted.
};
const char* toString(CandidateStatus status);

/// The best keyframe of one island of neighbouring candidates, and what became of it.
struct LoopCandidate {
  map::KeyframeId keyframe_id = 0;
  double score = 0.0;             ///< L1 bag-of-words score against the query, in [0, 1].
  double normalized_score = 0.0;  ///< score / the query's score against the previous keyframe.
  map::KeyframeId island_first_id = 0;
  map::KeyframeId island_last_id = 0;
  double island_score = 0.0;  ///< Sum of the island members' scores.
  GeometricCheckResult geometry;
  int consistent_queries = 0;  ///< Queries of the streak (this one included) verified nearby.
  CandidateStatus status = CandidateStatus::kFailedGeometry;
  std::string reason;  ///< Why it was not accepted; empty when accepted.
};

/// The answer to one query, with enough detail to log why nothing was accepted.
struct PlaceQueryResult {
  map::KeyframeId query_id = 0;
  bool searched = false;  ///< False when the query was skipped (skip_reason).
  std::string skip_reason;
  double reference_score = 0.0;  ///< Score of the query against the previous keyframe.
  int keyframes_considered = 0;  ///< Database keyframes outside the exclusions.
  int keyframes_above_threshold = 0;
  std::vector<LoopCandidate> candidates;  ///< Checked islands, best island first.

  /// The accepted candidate, if any (at most one per query).
  const LoopCandidate* accepted() const;
  /// One line for logs: the accepted loop or why there is none.
  std::string describe() const;
};

/// One keyframe of the database as a map file keeps it (system/map_snapshot.h).
struct SavedPlace {
  map::KeyframeId id = 0;
  double timestamp = 0.0;
  KeyframeAppearance appearance;
  /// Its bag of words and feature groups under the database's vocabulary, when it was indexed:
  /// restoring then skips the vocabulary descent of every descriptor.
  bool indexed = false;
  BowVector bow;
  FeatureGroups groups;
};

/// Finds earlier keyframes that show the place a new keyframe shows. Feed keyframes in order:
/// query(k) then add(k) (or queryAndAdd). Runs in the loop-closure thread; not thread-safe. Owns
/// the appearances of all keyframes added (about 41 kB each with 1000 keypoints) and shares the
/// vocabulary read-only.
class PlaceRecognizer {
 public:
  /// With a vocabulary (loaded from params.vocabulary_file or given), it is used as is; without,
  /// one is learned from the first params.online_training_keyframes keyframes. Throws
  /// std::invalid_argument on invalid params, std::runtime_error on an unreadable file.
  explicit PlaceRecognizer(PlaceRecognitionParams params,
                           std::shared_ptr<const Vocabulary> vocabulary = nullptr);

  /// Searches the database for the place `appearance` shows and updates the consistency
  /// bookkeeping (so call it once per keyframe, in order). `excluded` keyframes (for example
  /// those covisible with the query) are not proposed. Throws std::invalid_argument on an
  /// invalid appearance.
  PlaceQueryResult query(map::KeyframeId id, double timestamp, const KeyframeAppearance& appearance,
                         const std::unordered_set<map::KeyframeId>& excluded = {});
  /// Adds a keyframe to the database. Throws std::invalid_argument on a repeated id or an
  /// invalid appearance.
  void add(map::KeyframeId id, double timestamp, KeyframeAppearance appearance);
  /// Adds a saved keyframe: with its bag of words and groups as saved when `place.indexed` and
  /// the vocabulary is ready (they must come from this vocabulary), else as add(). Throws
  /// std::invalid_argument as add() does, or on words or feature indices out of range.
  void addSaved(SavedPlace place);
  /// query() then add().
  PlaceQueryResult queryAndAdd(map::KeyframeId id, double timestamp, KeyframeAppearance appearance,
                               const std::unordered_set<map::KeyframeId>& excluded = {});

  /// For relocalisation: the keyframes among all added so far that look most like `appearance`
  /// (scoring at least min_normalized_score of the best), best first, at most `max_candidates`,
  /// each checked with `geometry` (see LoopCandidate::geometry). No keyframe is
  /// excluded and the consistency bookkeeping of query() is untouched. Before the vocabulary is
  /// learned (a young map): the newest `max_candidates` keyframes, newest first, their
  /// descriptors matched by brute force (scores 0).
  std::vector<LoopCandidate> findPlaces(const KeyframeAppearance& appearance, int max_candidates,
                                        const GeometricCheckParams& geometry) const;

  /// Forgets a keyframe (culled by the mapper as redundant): it is never proposed again, and its
  /// features and bag of words are freed (before the vocabulary is learned, once it is: the
  /// learning needs them). An unknown id is ignored.
  void forget(map::KeyframeId id);

  /// Tells that the loop accepted at `query_id` failed metric verification: it no longer
  /// suppresses later candidates as its continuation.
  void reportLoopRejected(map::KeyframeId query_id);

  bool vocabularyReady() const { return vocabulary_ != nullptr; }
  std::shared_ptr<const Vocabulary> vocabulary() const { return vocabulary_; }
  std::size_t size() const { return keyframes_.size(); }
  /// Added and not forgotten.
  bool contains(map::KeyframeId id) const { return index_of_.count(id) != 0; }
  /// The stored appearance of a keyframe (loop verification matches against it). Throws
  /// std::out_of_range for an unknown id.
  const KeyframeAppearance& appearance(map::KeyframeId id) const;
  const PlaceRecognitionParams& params() const { return params_; }

  /// A keyframe of the database as added (what a map file keeps to rebuild it with add()).
  struct Place {
    map::KeyframeId id = 0;
    double timestamp = 0.0;
    const KeyframeAppearance* appearance = nullptr;  ///< Owned by the recognizer.
    const BowVector* bow = nullptr;                  ///< Null before the keyframe was indexed.
    const FeatureGroups* groups = nullptr;
  };
  /// The keyframes added so far and not forgotten, in the order they were added.
  std::vector<Place> places() const;

 private:
  struct Stored {
    map::KeyframeId id = 0;
    double timestamp = 0.0;
    KeyframeAppearance appearance;
    FeatureGroups groups;
    bool forgotten = false;
  };
  /// findPlaces() before the vocabulary is learned.
  std::vector<LoopCandidate> findRecentPlaces(const KeyframeAppearance& appearance,
                                              int max_candidates,
                                              const GeometricCheckParams& geometry) const;
  struct Island {
    std::size_t first = 0;
    std::size_t last = 0;
    std::size_t best = 0;
    double score = 0.0;  ///< Sum of the members' scores.
    double best_score = 0.0;
  };
  /// Candidates of earlier queries verified near [first, last] (document indices), `count`
  /// queries in a row, the last of them at query position `query`.
  struct ConsistencyGroup {
    std::size_t first = 0;
    std::size_t last = 0;
    int count = 0;
    std::size_t query = 0;
  };
  struct AcceptedLoop {
    map::KeyframeId accepted_query_id = 0;
    std::size_t last_query = 0;      ///< Document index the query had (or would have).
    std::size_t last_candidate = 0;  ///< Document index of the matched keyframe.
  };

  void trainOnlineVocabulary();
  /// Frees a forgotten keyframe's features and bag (once the vocabulary is learned).
  void release(std::size_t position);
  void index(std::size_t position);
  std::vector<Island> findIslands(const std::vector<float>& scores, double reference,
                                  std::size_t limit, double timestamp,
                                  const std::unordered_set<map::KeyframeId>& excluded,
                                  PlaceQueryResult& result) const;
  LoopCandidate checkIsland(const Island& island, double reference,
                            const KeyframeAppearance& appearance, const FeatureGroups& groups,
                            const GeometricCheckParams& geometry) const;
  void decide(std::size_t query_position, map::KeyframeId query_id,
              const std::vector<Island>& checked, PlaceQueryResult& result);

  PlaceRecognitionParams params_;
  std::shared_ptr<const Vocabulary> vocabulary_;
  /// In insertion order = document order once indexed. A deque: growing never copies the
  /// stored keyframes (a vector's reallocation copied them all, a transient peak of memory).
  std::deque<Stored> keyframes_;
  std::unordered_map<map::KeyframeId, std::size_t> index_of_;
  BowDatabase database_;
  /// Streaks a later query may still extend (at most `consistency_max_missed` queries old).
  std::vector<ConsistencyGroup> groups_;
  std::vector<AcceptedLoop> loops_;
};

}  // namespace scale_drift_slam::loop
