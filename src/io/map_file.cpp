#include "scale_drift_slam/io/map_file.h"

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <cereal/archives/portable_binary.hpp>
#include <cereal/types/array.hpp>
#include <cereal/types/string.hpp>
#include <cereal/types/unordered_map.hpp>
#include <cereal/types/utility.hpp>
#include <cereal/types/vector.hpp>

// How each saved type is written (cereal's non-member serialisation, found in namespace cereal).
// Every field is listed; the order is the format: change it only with kMapFileVersion.
namespace cereal {

namespace sds = scale_drift_slam;

template <class Archive, typename Scalar, int Rows, int Cols, int Options, int MaxRows, int MaxCols>
void serialize(Archive& ar, Eigen::Matrix<Scalar, Rows, Cols, Options, MaxRows, MaxCols>& m) {
  static_assert(Rows > 0 && Cols > 0, "fixed-size matrices only");
  for (int i = 0; i < m.size(); ++i)
    ar(m.data()[i]);
}

/// SE(3) and Sim(3) as their N parameters (toData / fromData).
template <std::size_t N, class Archive, class Group>
void saveParameters(Archive& ar, const Group& g) {
  double data[N];
  g.toData(data);
  for (const double d : data)
    ar(d);
}
template <std::size_t N, class Archive, class Group>
void loadParameters(Archive& ar, Group& g) {
  double data[N];
  for (double& d : data)
    ar(d);
  g = Group::fromData(data);
}

template <class Archive>
void save(Archive& ar, const sds::geometry::SE3& T) {
  saveParameters<7>(ar, T);
}
template <class Archive>
void load(Archive& ar, sds::geometry::SE3& T) {
  loadParameters<7>(ar, T);
}
template <class Archive>
void save(Archive& ar, const sds::geometry::Sim3& S) {
  saveParameters<8>(ar, S);
}
template <class Archive>
void load(Archive& ar, sds::geometry::Sim3& S) {
  loadParameters<8>(ar, S);
}

/// Grey images and descriptor tables: CV_8UC1 only (all the map holds).
template <class Archive>
void save(Archive& ar, const cv::Mat& m) {
  if (!m.empty() && m.type() != CV_8UC1) throw Exception("only CV_8UC1 matrices are saved");
  const cv::Mat dense = m.isContinuous() ? m : m.clone();
  ar(static_cast<std::int32_t>(dense.rows), static_cast<std::int32_t>(dense.cols));
  if (!dense.empty()) ar(binary_data(dense.data, dense.total()));
}
template <class Archive>
void load(Archive& ar, cv::Mat& m) {
  std::int32_t rows = 0, cols = 0;
  ar(rows, cols);
  if (rows < 0 || cols < 0 || static_cast<std::int64_t>(rows) * cols > (1LL << 28)) {
    throw Exception("bad matrix size");
  }
  m = cv::Mat();
  if (rows == 0 || cols == 0) return;
  m.create(rows, cols, CV_8UC1);
  ar(binary_data(m.data, m.total()));
}

template <class Archive>
void save(Archive& ar, const sds::geometry::CameraCalibration& c) {
  ar(static_cast<std::int32_t>(c.model), c.fx, c.fy, c.cx, c.cy, static_cast<std::int32_t>(c.width),
     static_cast<std::int32_t>(c.height), c.distortion);
}
template <class Archive>
void load(Archive& ar, sds::geometry::CameraCalibration& c) {
  std::int32_t model = 0, width = 0, height = 0;
  ar(model, c.fx, c.fy, c.cx, c.cy, width, height, c.distortion);
  if (model != static_cast<std::int32_t>(sds::geometry::DistortionModel::kRadialTangential) &&
      model != static_cast<std::int32_t>(sds::geometry::DistortionModel::kEquidistant)) {
    throw Exception("unknown lens model");
  }
  c.model = static_cast<sds::geometry::DistortionModel>(model);
  c.width = width;
  c.height = height;
}

/// Observations are held in single precision and written in double, as before they were held
/// so (the file format did not change).
template <class Archive>
void save(Archive& ar, const sds::map::Observation& o) {
  ar(o.point_id, o.xyd());
}
template <class Archive>
void load(Archive& ar, sds::map::Observation& o) {
  Eigen::Vector2d xy;
  ar(o.point_id, xy);
  o.xy = xy.cast<float>();
}

template <class Archive>
void serialize(Archive& ar, sds::map::Keyframe& k) {
  ar(k.id, k.timestamp, k.T_kf_world, k.observations);
}

template <class Archive>
void serialize(Archive& ar, sds::map::MapPoint& p) {
  ar(p.id, p.p_world, p.reference_keyframe, p.observed_by);
}

template <class Archive>
void save(Archive& ar, const sds::loop::PoseGraphEdge& e) {
  ar(e.from, e.to, e.S_from_to, e.information, static_cast<std::int32_t>(e.kind));
}
template <class Archive>
void load(Archive& ar, sds::loop::PoseGraphEdge& e) {
  std::int32_t kind = 0;
  ar(e.from, e.to, e.S_from_to, e.information, kind);
  if (kind < 0 || kind > static_cast<std::int32_t>(sds::loop::EdgeKind::kLoop)) {
    throw Exception("unknown edge kind");
  }
  e.kind = static_cast<sds::loop::EdgeKind>(kind);
}

template <class Archive>
void save(Archive& ar, const sds::features::PointAppearance& a) {
  ar(a.patch(0), a.patch(1), a.px_reference);
}
template <class Archive>
void load(Archive& ar, sds::features::PointAppearance& a) {
  cv::Mat level0, level1;
  ar(level0, level1, a.px_reference);
  try {
    a.setPatches(level0, level1);
  } catch (const std::invalid_argument& e) {
    throw Exception(e.what());
  }
}

template <class Archive>
void save(Archive& ar, const sds::loop::KeyframeAppearance& a) {
  std::vector<float> xy;
  xy.reserve(2 * a.keypoints.size());
  for (const cv::Point2f& p : a.keypoints) {
    xy.push_back(p.x);
    xy.push_back(p.y);
  }
  ar(static_cast<std::int32_t>(a.image_width), static_cast<std::int32_t>(a.image_height),
     a.undistorted, xy, a.octaves, a.descriptors);
}
template <class Archive>
void load(Archive& ar, sds::loop::KeyframeAppearance& a) {
  std::int32_t width = 0, height = 0;
  std::vector<float> xy;
  ar(width, height, a.undistorted, xy, a.octaves, a.descriptors);
  if (xy.size() % 2 != 0) throw Exception("odd keypoint coordinate count");
  a.image_width = width;
  a.image_height = height;
  a.keypoints.clear();
  for (std::size_t i = 0; i < xy.size(); i += 2)
    a.keypoints.emplace_back(xy[i], xy[i + 1]);
}

template <class Archive>
void serialize(Archive& ar, sds::loop::BowVector& bow) {
  ar(bow.words, bow.weights);
}

template <class Archive>
void serialize(Archive& ar, sds::loop::FeatureGroups& groups) {
  ar(groups.nodes, groups.features);
}

template <class Archive>
void serialize(Archive& ar, sds::loop::SavedPlace& p) {
  ar(p.id, p.timestamp, p.appearance, p.indexed, p.bow, p.groups);
}

}  // namespace cereal

namespace scale_drift_slam::io {
namespace {

constexpr char kMagic[8] = {'S', 'D', 'S', 'M', 'A', 'P', '\r', '\n'};
constexpr std::size_t kHeaderBytes = 8 + 4 + 4 + 8 + 8;  // magic, version, reserved, size, sum

/// The payload's checksum: FNV-1a over little-endian 64-bit words in four interleaved lanes (each
/// step (h ^ w) * prime is a bijection of h, so any change of one word changes its lane and the
/// result), then the lanes, the trailing bytes and the size. Eight times fewer multiplications
/// than bytewise FNV-1a: ~0.1 s for a 250 MB map.
std::uint64_t checksum(const char* data, std::size_t size) {
  constexpr std::uint64_t kOffset = 1469598103934665603ull, kPrime = 1099511628211ull;
  std::uint64_t lane[4] = {kOffset, kOffset ^ 1, kOffset ^ 2, kOffset ^ 3};
  std::size_t i = 0;
  for (; i + 32 <= size; i += 32) {
    for (int l = 0; l < 4; ++l) {
      std::uint64_t word = 0;
      std::memcpy(&word, data + i + 8 * l, 8);
#if __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
      word = __builtin_bswap64(word);
#endif
      lane[l] = (lane[l] ^ word) * kPrime;
    }
  }
  std::uint64_t hash = kOffset;
  for (const std::uint64_t value : lane)
    hash = (hash ^ value) * kPrime;
  for (; i < size; ++i)
    hash = (hash ^ static_cast<unsigned char>(data[i])) * kPrime;
  return (hash ^ size) * kPrime;
}

/// An input stream over bytes held elsewhere (no copy of a 100 MB payload).
class MemoryBuffer : public std::streambuf {
 public:
  MemoryBuffer(const char* data, std::size_t size) {
    char* begin = const_cast<char*>(data);  // read only: the get area is never written
    setg(begin, begin, begin + size);
  }
};

/// Little-endian fixed-width integers of the header.
template <typename T>
void putLittle(std::string& out, T value) {
  for (std::size_t i = 0; i < sizeof(T); ++i)
    out.push_back(static_cast<char>((static_cast<std::uint64_t>(value) >> (8 * i)) & 0xff));
}
template <typename T>
T getLittle(const std::string& in, std::size_t offset) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i)
    value |= static_cast<std::uint64_t>(static_cast<unsigned char>(in[offset + i])) << (8 * i);
  return static_cast<T>(value);
}

/// The map as lists (points by id, keyframes in id order).
struct MapLists {
  std::vector<map::Keyframe> keyframes;
  std::vector<map::MapPoint> points;
};

MapLists listsOf(const map::Map& map) {
  MapLists lists;
  for (const auto& entry : map.keyframes())
    lists.keyframes.push_back(entry.second);
  for (const auto& entry : map.points())
    lists.points.push_back(entry.second);
  std::sort(lists.points.begin(), lists.points.end(),
            [](const map::MapPoint& a, const map::MapPoint& b) { return a.id < b.id; });
  return lists;
}

/// Rebuilds the map through its own checks; the observers must be those of the observations.
map::Map mapOf(MapLists lists) {
  map::Map map;
  std::unordered_map<map::PointId, std::vector<map::KeyframeId>> saved_observers;
  for (map::MapPoint& point : lists.points) {
    saved_observers[point.id] = std::move(point.observed_by);
    point.observed_by.clear();
    map.addPoint(std::move(point));
  }
  for (map::Keyframe& keyframe : lists.keyframes)
    map.addKeyframe(std::move(keyframe));
  for (auto& [id, point] : map.points()) {
    std::vector<map::KeyframeId>& saved = saved_observers[id];
    std::vector<map::KeyframeId> a = saved, b = point.observed_by;
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    if (a != b) {
      throw std::invalid_argument("point " + std::to_string(id) +
                                  ": its observers disagree with the observations");
    }
    point.observed_by = std::move(saved);  // the saved order
  }
  return map;
}

std::string serialisePayload(const MapFile& file) {
  std::ostringstream stream(std::ios::binary);
  {
    cereal::PortableBinaryOutputArchive ar(stream);
    const system::MapSnapshot& s = file.snapshot;
    MapLists lists = listsOf(s.map);
    std::vector<std::pair<map::PointId, features::PointAppearance>> appearances(
        s.point_appearances.begin(), s.point_appearances.end());
    std::sort(appearances.begin(), appearances.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<std::pair<map::KeyframeId, std::vector<std::uint8_t>>> images(
        s.keyframe_images.begin(), s.keyframe_images.end());
    std::sort(images.begin(), images.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    ar(file.calibration, file.params_yaml, file.map_version, lists.keyframes, lists.points,
       s.loop_edges, appearances, s.vocabulary, s.places, images);
  }
  return stream.str();
}

MapFile parsePayload(const char* payload, std::size_t size, bool validate = true) {
  MemoryBuffer buffer(payload, size);
  std::istream stream(&buffer);
  cereal::PortableBinaryInputArchive ar(stream);
  MapFile file;
  MapLists lists;
  std::vector<std::pair<map::PointId, features::PointAppearance>> appearances;
  std::vector<std::pair<map::KeyframeId, std::vector<std::uint8_t>>> images;
  system::MapSnapshot& s = file.snapshot;
  ar(file.calibration, file.params_yaml, file.map_version, lists.keyframes, lists.points,
     s.loop_edges, appearances, s.vocabulary, s.places, images);
  if (stream.peek() != std::char_traits<char>::eof()) {
    throw std::invalid_argument("trailing bytes after the map");
  }
  s.map = mapOf(std::move(lists));
  for (auto& [id, appearance] : appearances) {
    if (!s.point_appearances.emplace(id, std::move(appearance)).second) {
      throw std::invalid_argument("two appearances of point " + std::to_string(id));
    }
  }
  for (auto& [id, jpeg] : images) {
    if (!s.keyframe_images.emplace(id, std::move(jpeg)).second) {
      throw std::invalid_argument("two images of keyframe " + std::to_string(id));
    }
  }
  if (validate) {
    file.calibration.validate();
    s.validate();
  }
  return file;
}

std::string readWhole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw MapFileError(MapFileError::Kind::kUnreadable, "map file '" + path + "': cannot open");
  }
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  std::string data(size > 0 ? static_cast<std::size_t>(size) : 0, '\0');
  if (size < 0 || !in.read(data.data(), static_cast<std::streamsize>(data.size()))) {
    throw MapFileError(MapFileError::Kind::kUnreadable, "map file '" + path + "': read error");
  }
  return data;
}

/// The payload's size after a checked header; throws what is wrong with the header or the sum.
std::size_t checkedPayload(const std::string& data, const std::string& path) {
  using Kind = MapFileError::Kind;
  const std::string name = "map file '" + path + "': ";
  if (data.size() < sizeof(kMagic) || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
    throw MapFileError(Kind::kNotAMapFile, name + "not a map file (no SDSMAP magic)");
  }
  if (data.size() < kHeaderBytes) throw MapFileError(Kind::kTruncated, name + "truncated header");
  const auto version = getLittle<std::uint32_t>(data, 8);
  if (version != kMapFileVersion) {
    throw MapFileError(Kind::kOtherVersion, name + "format version " + std::to_string(version) +
                                                ", this build reads version " +
                                                std::to_string(kMapFileVersion));
  }
  const auto size = getLittle<std::uint64_t>(data, 16);
  const auto sum = getLittle<std::uint64_t>(data, 24);
  if (data.size() - kHeaderBytes != size) {
    throw MapFileError(Kind::kTruncated,
                       name + "truncated: " + std::to_string(data.size() - kHeaderBytes) +
                           " payload bytes, the header says " + std::to_string(size));
  }
  if (checksum(data.data() + kHeaderBytes, size) != sum) {
    throw MapFileError(Kind::kCorrupted, name + "checksum mismatch (the file is corrupted)");
  }
  return size;
}

}  // namespace

void saveMapFile(const std::string& path, const MapFile& file) {
  const std::string payload = serialisePayload(file);
  std::string header(kMagic, sizeof(kMagic));
  putLittle<std::uint32_t>(header, kMapFileVersion);
  putLittle<std::uint32_t>(header, 0);  // reserved
  putLittle<std::uint64_t>(header, payload.size());
  putLittle<std::uint64_t>(header, checksum(payload.data(), payload.size()));
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path temporary =
      target.parent_path() / ("." + target.filename().string() + ".tmp" + std::to_string(getpid()));
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out || !out.write(header.data(), static_cast<std::streamsize>(header.size())) ||
        !out.write(payload.data(), static_cast<std::streamsize>(payload.size())) || !out.flush()) {
      std::error_code ignored;
      fs::remove(temporary, ignored);
      throw MapFileError(MapFileError::Kind::kUnreadable,
                         "map file '" + path + "': cannot write " + temporary.string());
    }
  }
  std::error_code error;
  fs::rename(temporary, target, error);
  if (error) {
    fs::remove(temporary, error);
    throw MapFileError(MapFileError::Kind::kUnreadable,
                       "map file '" + path + "': cannot rename the temporary file over it");
  }
}

MapFile loadMapFile(const std::string& path) {
  const std::string data = readWhole(path);
  const std::size_t size = checkedPayload(data, path);
  try {
    MapFile file = parsePayload(data.data() + kHeaderBytes, size);
    file.checksum = getLittle<std::uint64_t>(data, 24);
    return file;
  } catch (const std::exception& e) {  // cereal::Exception, std::invalid_argument, bad_alloc
    throw MapFileError(MapFileError::Kind::kMalformed,
                       "map file '" + path + "': malformed content: " + e.what());
  }
}

std::uint32_t mapFileSession(const MapFile& file) {
  return static_cast<std::uint32_t>(file.checksum ^ (file.checksum >> 32)) | 1u;
}

std::string encodeSnapshotPart(const system::MapSnapshot& part) {
  MapFile file;
  file.snapshot = part;
  return serialisePayload(file);
}

system::MapSnapshot decodeSnapshotPart(const std::string& bytes) {
  try {
    return parsePayload(bytes.data(), bytes.size(), false).snapshot;
  } catch (const std::exception& e) {
    throw MapFileError(MapFileError::Kind::kMalformed,
                       std::string("a part of a map: malformed content: ") + e.what());
  }
}

void checkMapCamera(const MapFile& file, const geometry::CameraCalibration& camera,
                    const std::string& path) {
  if (file.calibration.sameCameraAs(camera)) return;
  throw MapFileError(MapFileError::Kind::kOtherCamera,
                     "map file '" + path + "' was made with another camera (" +
                         file.calibration.describe() + ") than this run's (" + camera.describe() +
                         ")");
}

}  // namespace scale_drift_slam::io
