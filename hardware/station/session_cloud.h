// A project session's cloud (core/project/project.h), built the one way the
// CLI's `project` commands and the desktop app's project tree build it: the
// session folder decoded (streamed, session_stream.h), its poses from the
// EKF (or the wheels alone) starting at the identity, so the cloud is in
// the session's own frame (where the operator put the robot down) whatever
// meta.json says about a simulated or imported start, under the project's
// calibration for it or the session's own.
//
// Pure functions, no Qt; any thread (the app loads clouds on a worker).
#ifndef SWEEPSCAN_HARDWARE_STATION_SESSION_CLOUD_H_
#define SWEEPSCAN_HARDWARE_STATION_SESSION_CLOUD_H_

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/common/status.h"
#include "core/geometry/transform.h"
#include "core/pose/pose_estimator.h"
#include "core/project/project.h"
#include "core/session/session.h"
#include "hardware/link/telemetry_decoder.h"

namespace sweepscan::hardware {

struct SessionCloudOptions {
  PoseSource pose_source = PoseSource::kEkf;  // kEkf or kOdometry
  // Skip damaged records (the default, as everywhere a session is opened:
  // the app's project view built its clouds refusing them, though it says
  // a cloud's damage) or refuse them (the CLI's --strict).
  FramesLoadOptions frames = DefaultSessionFramesOptions();
  DecodeProgress progress;                    // 0..1 of the decoding; false cancels
};

struct SessionCloud {
  std::string id;
  std::string dir;  // the resolved session folder
  SessionMeta meta;
  std::string damage;  // frames.bin's damage summary, "" if none (warn the operator)
  MountingError calibration;  // what the cloud was built with
  std::vector<CloudPoint> points;  // the session's own frame
  // A simulated session (meta.json's settings.scenario): the scenario's
  // start pose, the truth of where the operator put the robot down. Only
  // for checking registrations against truth; never used to place a cloud.
  bool has_true_start = false;
  Rigid3d world_from_session_truth;
};

// The cloud with the session decoded whole (recording.h) and
// reconstructed at once: 24 bytes a lidar sample and 32 a point at its
// peak. The programs stream it (below); this is the reference the streamed
// clouds are tested against, point for point.
Status LoadSessionCloud(const std::string& project_file, const ProjectSession& session,
                        const SessionCloudOptions& options, SessionCloud* cloud);

// The same cloud streamed (session_stream.h: frames.bin read twice record
// by record, each scan placed as it is decoded): `sink` gets its points in
// order, in the session's frame, at most 65 536 a call on a thread of the
// stream's own; an error it returns stops the stream and is returned.
// `reserve` (may be empty) gets, before the first point, a bound on their
// number. `cloud` gets all but its points. The progress runs 0..0.5 over
// the first pass, 0.5..1 over the second.
Status StreamSessionCloud(const std::string& project_file, const ProjectSession& session,
                          const SessionCloudOptions& options, SessionCloud* cloud,
                          const std::function<Status(const CloudPoint*, size_t)>& sink,
                          const std::function<void(size_t bound)>& reserve = nullptr);

// StreamSessionCloud's positions alone, into `positions` (12 bytes a
// point). The decoded session and its 32-byte points are never held: a
// 99.5 M-point session's cloud peaked at 7.3 GB through LoadSessionCloud.
Status LoadSessionPositions(const std::string& project_file, const ProjectSession& session,
                            const SessionCloudOptions& options, SessionCloud* cloud,
                            std::vector<Eigen::Vector3f>* positions);

// p <- t * p for every point (double precision in, float out).
void TransformPoints(const Rigid3d& t, std::vector<CloudPoint>* points);
void TransformPoints(const Rigid3d& t, CloudPoint* points, size_t n);
std::vector<Eigen::Vector3f> Positions(const std::vector<CloudPoint>& points);

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_STATION_SESSION_CLOUD_H_
