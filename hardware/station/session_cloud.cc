#include "hardware/station/session_cloud.h"

#include "core/cloud/reconstruct.h"
#include "hardware/station/recording.h"
#include "hardware/station/session_stream.h"

namespace sweepscan::hardware {

namespace {

// The folder still holds the recording that was added to the project: a
// room recorded again under the same name (its folder replaced) is another
// cloud, and the placements were measured on the first.
Status CheckSameRecording(const ProjectSession& session, const std::string& dir,
                          const SessionMeta& meta) {
  if (session.recorded_utc.empty() || meta.created_utc.empty() ||
      meta.created_utc == session.recorded_utc)
    return Status::Ok();
  return Status::Error(dir + " now holds another recording (begun " + meta.created_utc +
                       ") than the one added to the project (begun " + session.recorded_utc +
                       "): its placement was measured on that one; remove the session from the "
                       "project and add it again");
}

}  // namespace

Status StreamSessionCloud(const std::string& project_file, const ProjectSession& session,
                          const SessionCloudOptions& options, SessionCloud* cloud,
                          const std::function<Status(const CloudPoint*, size_t)>& sink,
                          const std::function<void(size_t bound)>& reserve) {
  if (options.pose_source != PoseSource::kEkf && options.pose_source != PoseSource::kOdometry) {
    return Status::Error("a project's session clouds are built from the EKF or the wheels alone");
  }
  SessionCloud out;
  out.id = session.id;
  out.dir = ResolveSessionPath(project_file, session);
  const auto refuse = [&](const Status& s) {
    return Status::Error("session '" + session.id + "': " + s.message());
  };
  Status s = ReadSessionMeta(out.dir + "/" + kSessionMetaFile, &out.meta);
  if (s.ok()) s = CheckSameRecording(session, out.dir, out.meta);
  if (!s.ok()) return refuse(s);
  const nlohmann::json& settings = out.meta.settings;
  if (settings.is_object() && settings.contains("scenario")) {
    const Pose2d start = SessionStartPose(out.meta);
    out.has_true_start = true;
    out.world_from_session_truth = Rigid3d::FromPose(start.x, start.y, 0.0, 0.0, 0.0, start.yaw);
  }
  // The session's own frame: the poses start at the identity (as LoadSessionCloud's).
  ReconstructionOptions ro;
  ro.pose.source = options.pose_source;
  ro.calibration = session.calibration ? *session.calibration : out.meta.calibration;
  out.calibration = ro.calibration;
  const auto half = [&](double from) -> DecodeProgress {
    if (!options.progress) return nullptr;
    return [&options, from](double f) { return options.progress(from + 0.5 * f); };
  };
  SessionCloudStream stream;
  s = stream.EstimatePoses(out.dir, options.frames, ro, nullptr, half(0.0));
  if (!s.ok()) return refuse(s);
  if (!stream.decode().frames.damage.empty()) out.damage = stream.decode().frames.DamageSummary();
  if (reserve) reserve(stream.PointBound());
  s = stream.PlacePoints(sink, half(0.5));
  if (!s.ok()) return refuse(s);
  *cloud = std::move(out);
  return Status::Ok();
}

Status LoadSessionPositions(const std::string& project_file, const ProjectSession& session,
                            const SessionCloudOptions& options, SessionCloud* cloud,
                            std::vector<Eigen::Vector3f>* positions) {
  positions->clear();
  return StreamSessionCloud(
      project_file, session, options, cloud,
      [positions](const CloudPoint* p, size_t n) {
        for (size_t i = 0; i < n; ++i) positions->emplace_back(p[i].x, p[i].y, p[i].z);
        return Status::Ok();
      },
      [positions](size_t bound) { positions->reserve(bound); });
}

Status LoadSessionCloud(const std::string& project_file, const ProjectSession& session,
                        const SessionCloudOptions& options, SessionCloud* cloud) {
  if (options.pose_source != PoseSource::kEkf && options.pose_source != PoseSource::kOdometry) {
    return Status::Error("a project's session clouds are built from the EKF or the wheels alone");
  }
  SessionCloud out;
  out.id = session.id;
  out.dir = ResolveSessionPath(project_file, session);
  Recording rec;
  Status s = ReadSessionMeta(out.dir + "/" + kSessionMetaFile, &out.meta);
  if (s.ok()) s = CheckSameRecording(session, out.dir, out.meta);
  if (s.ok()) s = OpenRecording(out.dir, options.frames, &rec, options.progress);
  if (!s.ok()) return Status::Error("session '" + session.id + "': " + s.message());
  out.meta = rec.decode.meta;
  if (!rec.decode.frames.damage.empty()) out.damage = rec.decode.frames.DamageSummary();
  const nlohmann::json& settings = out.meta.settings;
  if (settings.is_object() && settings.contains("scenario")) {
    const Pose2d start = rec.start;
    out.has_true_start = true;
    out.world_from_session_truth = Rigid3d::FromPose(start.x, start.y, 0.0, 0.0, 0.0, start.yaw);
  }
  // The session's own frame: the robot's pose at its first record.
  rec.start = Pose2d();
  ReconstructionOptions ro;
  ro.pose.source = options.pose_source;
  ro.calibration = session.calibration ? *session.calibration : out.meta.calibration;
  out.calibration = ro.calibration;
  ReconstructionResult result;
  s = ReconstructRecording(rec, ro, &result);
  if (!s.ok()) return Status::Error("session '" + session.id + "': " + s.message());
  out.points = std::move(result.points);
  *cloud = std::move(out);
  return Status::Ok();
}

void TransformPoints(const Rigid3d& t, CloudPoint* points, size_t n) {
  const Eigen::Matrix3d r = t.rotation().toRotationMatrix();
  const Eigen::Vector3d o = t.translation();
  for (size_t i = 0; i < n; ++i) {
    CloudPoint& p = points[i];
    const Eigen::Vector3d q = r * Eigen::Vector3d(p.x, p.y, p.z) + o;
    p.x = static_cast<float>(q.x());
    p.y = static_cast<float>(q.y());
    p.z = static_cast<float>(q.z());
  }
}

void TransformPoints(const Rigid3d& t, std::vector<CloudPoint>* points) {
  TransformPoints(t, points->data(), points->size());
}

std::vector<Eigen::Vector3f> Positions(const std::vector<CloudPoint>& points) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(points.size());
  for (const CloudPoint& p : points) out.emplace_back(p.x, p.y, p.z);
  return out;
}

}  // namespace sweepscan::hardware
