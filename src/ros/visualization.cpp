#include "scale_drift_slam/ros/visualization.h"

#include <cstdio>

#include <sensor_msgs/point_cloud2_iterator.h>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/frames.h"

namespace scale_drift_slam::ros_conversions {
namespace {

geometry_msgs::Point toPoint(const Eigen::Vector3d& p) {
  geometry_msgs::Point point;
  point.x = p.x();
  point.y = p.y();
  point.z = p.z();
  return point;
}

std_msgs::ColorRGBA colour(float r, float g, float b) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = 1.0f;
  return c;
}

visualization_msgs::Marker lineMarker(const std_msgs::Header& header, const std::string& ns,
                                      int type, double width, const std_msgs::ColorRGBA& c) {
  visualization_msgs::Marker marker;
  marker.header = header;
  marker.ns = ns;
  marker.id = 0;
  marker.type = type;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = width;
  marker.color = c;
  return marker;
}

/// A marker with nothing to show is deleted (rviz warns about empty line lists).
visualization_msgs::Marker finish(visualization_msgs::Marker marker, std::size_t min_points) {
  if (marker.points.size() < min_points) {
    marker.action = visualization_msgs::Marker::DELETE;
    marker.points.clear();
  }
  return marker;
}

}  // namespace

sensor_msgs::PointCloud2 mapCloud(const map::Map& map, const geometry::SE3& T_map_world,
                                  const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(map.numPoints());
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (const auto& [id, point] : map.points()) {
    const Eigen::Vector3d p = T_map_world * point.p_world;
    *x = static_cast<float>(p.x());
    *y = static_cast<float>(p.y());
    *z = static_cast<float>(p.z());
    ++x;
    ++y;
    ++z;
  }
  return cloud;
}

visualization_msgs::MarkerArray keyframeMarkers(
    const map::Map& map, const std::vector<std::pair<map::KeyframeId, map::KeyframeId>>& loops,
    const geometry::SE3& T_map_world, const std_msgs::Header& header, double frustum_size) {
  using visualization_msgs::Marker;
  Marker frustums = lineMarker(header, "keyframes", Marker::LINE_LIST, 0.1 * frustum_size,
                               colour(0.2f, 0.4f, 1.0f));
  Marker path = lineMarker(header, "keyframe_path", Marker::LINE_STRIP, 0.1 * frustum_size,
                           colour(0.2f, 0.8f, 1.0f));
  Marker edges = lineMarker(header, "loop_edges", Marker::LINE_LIST, 0.5 * frustum_size,
                            colour(1.0f, 0.2f, 0.2f));
  // The keyframes a loop joins, as balls: a loop edge is often shorter than the path is wide.
  Marker ends = lineMarker(header, "loop_edges", Marker::SPHERE_LIST, 2.0 * frustum_size,
                           colour(1.0f, 0.2f, 0.2f));
  ends.id = 1;
  ends.scale.y = ends.scale.z = ends.scale.x;
  // Frustum corners in the camera's optical frame: apex at 0, image rectangle at depth d.
  const double d = frustum_size, w = 0.6 * frustum_size, h = 0.45 * frustum_size;
  const std::vector<Eigen::Vector3d> corners = {{-w, -h, d}, {w, -h, d}, {w, h, d}, {-w, h, d}};
  for (const auto& [id, keyframe] : map.keyframes()) {
    const geometry::SE3 T_map_kf = T_map_world * keyframe.T_kf_world.inverse();
    const Eigen::Vector3d& apex = T_map_kf.translation();
    for (std::size_t i = 0; i < corners.size(); ++i) {
      const Eigen::Vector3d a = T_map_kf * corners[i];
      const Eigen::Vector3d b = T_map_kf * corners[(i + 1) % corners.size()];
      frustums.points.insert(frustums.points.end(), {toPoint(apex), toPoint(a)});
      frustums.points.insert(frustums.points.end(), {toPoint(a), toPoint(b)});
    }
    path.points.push_back(toPoint(apex));
  }
  for (const auto& [from, to] : loops) {
    if (!map.hasKeyframe(from) || !map.hasKeyframe(to)) continue;
    for (const map::KeyframeId id : {from, to}) {
      edges.points.push_back(
          toPoint(T_map_world * map.keyframe(id).T_kf_world.inverseTranslation()));
    }
  }
  ends.points = edges.points;
  visualization_msgs::MarkerArray markers;
  markers.markers = {finish(frustums, 2), finish(path, 2), finish(edges, 2), finish(ends, 2)};
  return markers;
}

geometry_msgs::PoseStamped pathPose(const geometry::SE3& T_cam_world, double timestamp,
                                    const geometry::SE3& T_map_world,
                                    const std::string& map_frame) {
  static const geometry::SE3 T_optical_body = ros_conversions::bodyFromOptical().inverse();
  geometry_msgs::PoseStamped pose;
  pose.header.stamp = ros::Time(timestamp);
  pose.header.frame_id = map_frame;
  pose.pose = ros_conversions::toPoseMsg(T_map_world * T_cam_world.inverse() * T_optical_body);
  return pose;
}

CameraPath::CameraPath(const geometry::SE3& T_map_world, std::string map_frame,
                       std::size_t max_poses)
    : T_map_world_(T_map_world), max_poses_(max_poses) {
  path_.header.frame_id = std::move(map_frame);
}

void CameraPath::add(double timestamp, const geometry::SE3& T_cam_world,
                     std::optional<map::KeyframeId> reference_keyframe) {
  trajectory_.add(timestamp, T_cam_world, reference_keyframe);
  if (trajectory_.size() > 2 * max_poses_) trajectory_.keepNewest(max_poses_);
  path_.poses.push_back(pathPose(T_cam_world, timestamp, T_map_world_, path_.header.frame_id));
  if (path_.poses.size() > max_poses_) path_.poses.erase(path_.poses.begin());
}

void CameraPath::rebuild() {
  const std::vector<map::CorrectedTrajectory::Frame>& frames = trajectory_.frames();
  const std::size_t first = frames.size() > max_poses_ ? frames.size() - max_poses_ : 0;
  path_.poses.clear();
  for (std::size_t i = first; i < frames.size(); ++i) {
    path_.poses.push_back(
        pathPose(frames[i].T_cam_world, frames[i].timestamp, T_map_world_, path_.header.frame_id));
  }
}

void CameraPath::clear() {
  trajectory_.clear();
  path_.poses.clear();
}

const nav_msgs::Path& CameraPath::message(const ros::Time& stamp) {
  path_.header.stamp = stamp;
  return path_;
}

visualization_msgs::MarkerArray deleteAllMarkers(const std_msgs::Header& header) {
  visualization_msgs::Marker marker;
  marker.header = header;
  marker.action = visualization_msgs::Marker::DELETEALL;
  visualization_msgs::MarkerArray markers;
  markers.markers.push_back(marker);
  return markers;
}

cv::Mat debugImage(const cv::Mat& grey, const tracking::FrameResult& result) {
  cv::Mat image;
  cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
  for (const Eigen::Vector2d& px : result.tracked_px) {
    cv::circle(image, cv::Point2d(px.x(), px.y()), 4, cv::Scalar(0, 230, 0), 2, cv::LINE_AA);
  }
  char text[160];
  std::snprintf(text, sizeof(text), "%s  inliers %d  matches %d  %.1f ms",
                tracking::trackingStateName(result.state).c_str(), result.num_inliers,
                result.num_found, result.times.total);
  const double scale = std::max(0.4, image.cols / 800.0);  // readable at half size in rviz
  const auto put = [&](const std::string& line, int row) {
    const cv::Point origin(8, static_cast<int>((row + 1) * 34 * scale));
    cv::putText(image, line, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 4,
                cv::LINE_AA);
    cv::putText(image, line, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 255, 255), 2,
                cv::LINE_AA);
  };
  put(text, 0);
  if (!result.message.empty()) put(result.message, 1);
  return image;
}

sensor_msgs::Image debugImageMsg(const CameraImage& image, const tracking::FrameResult& result,
                                 const std_msgs::Header& header, const std::string& frame_id) {
  std_msgs::Header debug_header = header;
  debug_header.frame_id = frame_id;
  return toBgr8Msg(debugImage(features::toGrey(image.image, image.encoding), result), debug_header);
}

}  // namespace scale_drift_slam::ros_conversions
