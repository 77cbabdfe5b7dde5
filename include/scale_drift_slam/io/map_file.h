#pragma once
// Map files (doc/map_file.md): a saved map (system::MapSnapshot) with the camera calibration and
// the parameters it was made with, so that a later run can relocalise in it, localise against it
// or extend it. Layout: a 32-byte header (magic "SDSMAP\r\n", format version, payload size, a
// 64-bit FNV-1a checksum of the payload) and the payload, a cereal portable binary archive.
// Written atomically: to a temporary file in the same folder, then renamed over the target, so a
// crash or a full disk never leaves a half-written map under the name.

#include <cstdint>
#include <stdexcept>
#include <string>

#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/system/map_snapshot.h"

namespace scale_drift_slam::io {

/// The format version this build writes and reads.
constexpr std::uint32_t kMapFileVersion = 1;

struct MapFile {
  geometry::CameraCalibration calibration;  ///< The camera the map was made with.
  std::string params_yaml;        ///< The SLAM parameters of the run (io::formatSlamParams).
  std::uint64_t map_version = 0;  ///< The saved map's version (map::Map::version) when saved.
  system::MapSnapshot snapshot;
  /// Set by loadMapFile: the payload's checksum from the header (not written; saveMapFile makes
  /// its own). The ROS nodes derive the loaded map's tracker session from it (mapFileSession).
  std::uint64_t checksum = 0;
};

/// The tracker session under which the ROS nodes that load the same file restore its map
/// (doc/map_file.md, "In ROS"): a function of the file's checksum, never 0, so that the tracking,
/// mapping and loop-closure nodes agree on it without talking to each other.
std::uint32_t mapFileSession(const MapFile& file);

/// Parts of a map sent between the ROS nodes (the tracker's point appearances, the loop closer's
/// database) to the mapping node that writes the file: the snapshot serialised as the payload is,
/// without the header and without MapSnapshot::validate (a part alone is not a whole map).
std::string encodeSnapshotPart(const system::MapSnapshot& part);
/// Throws MapFileError (kMalformed) when the bytes do not parse.
system::MapSnapshot decodeSnapshotPart(const std::string& bytes);

/// Why a map file was refused.
class MapFileError : public std::runtime_error {
 public:
  enum class Kind {
    kUnreadable,    ///< Missing or unreadable (or, saving, not writable).
    kNotAMapFile,   ///< No map file magic.
    kOtherVersion,  ///< Another format version.
    kTruncated,     ///< Shorter than its header says (or longer).
    kCorrupted,     ///< Checksum mismatch.
    kMalformed,     ///< Checksum right but the content does not parse or is inconsistent.
    kOtherCamera,   ///< Made with another camera than the run's.
  };
  MapFileError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

/// Writes `file` to `path` atomically. Throws MapFileError (kUnreadable) naming the path when it
/// cannot; the previous file at `path`, if any, is then untouched.
void saveMapFile(const std::string& path, const MapFile& file);

/// Reads and checks a map file (header, checksum, content, MapSnapshot::validate). Throws
/// MapFileError with the kind and a message naming the file and the problem.
MapFile loadMapFile(const std::string& path);

/// Throws MapFileError (kOtherCamera) when the map was made with another camera than `camera`
/// (geometry::CameraCalibration::sameCameraAs), naming both.
void checkMapCamera(const MapFile& file, const geometry::CameraCalibration& camera,
                    const std::string& path);

}  // namespace scale_drift_slam::io
