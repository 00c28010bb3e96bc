// The project's long work off the GUI thread (docs/architecture.md,
// "Threads"): building session clouds (hardware/station/session_cloud.h)
// and registering a session against a placed one
// (hardware/station/project_align.h, the CLI's step). One job at a time
// on its own std::thread; progress and the result come back to the GUI
// thread as queued calls; Cancel() stops the decoder or the registration
// within about 100 ms.
//
// The runner lives on the GUI thread; the work functions run on the job
// thread and touch no Qt widget or VTK object.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_JOBS_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_JOBS_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <QObject>
#include <QString>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "core/geometry/transform.h"
#include "core/project/project.h"

namespace sweepscan::ui {

// A session's cloud as the project needs it: positions in the session's
// own frame (12 bytes a point), immutable once built and shared between
// the view and registrations.
struct ProjectCloud {
  std::string id;
  std::string key;  // CloudKey() it was built for
  std::vector<Eigen::Vector3f> positions;
  Eigen::AlignedBox3f bounds;  // of the positions (empty if none)
  // The bounds of each kPickBlock positions in order (a second of scanning,
  // a compact slab), and of each kPickPiece within them (a tenth of a scan
  // line, under a metre of wall: a slab's box is crossed by most rays
  // through the room, a piece's only by those that pass near it). A pick
  // tests the pieces its ray passes near in the blocks it meets, nearest
  // first. 0.38 bytes a point for the pieces.
  static constexpr size_t kPickBlock = 4096;
  static constexpr size_t kPickPiece = 64;
  std::vector<Eigen::AlignedBox3f> block_bounds;
  std::vector<Eigen::AlignedBox3f> piece_bounds;
  // The cubes of the rest level planned for the camera (project_detail.h):
  // each piece's 0.5 m cube (of its box's centre; PackedChunk::CellKey), as
  // an index into cube_keys. 0.06 bytes a point.
  std::vector<uint32_t> piece_cubes;
  std::vector<uint64_t> cube_keys;
  std::string damage;  // frames.bin's damage, "" if none
  bool has_truth = false;  // a simulated session: where the robot was put down
  Rigid3d world_from_session_truth;
};
using ProjectCloudPtr = std::shared_ptr<const ProjectCloud>;

// Sets `cloud`'s bounds, block_bounds, piece_bounds and census from its
// positions.
void IndexForPicks(ProjectCloud* cloud);
// Whether `cloud` holds that index for every point (a cloud made without
// IndexForPicks is picked point by point and never planned for the camera).
bool IndexedForPicks(const ProjectCloud& cloud);

// What a session's cloud depends on: a session whose folder (absolute, so
// that the project saved elsewhere keeps its clouds) or calibration
// changes is built again.
std::string CloudKey(const std::string& project_file, const ProjectSession& session);

// Builds the cloud of `session` of the project file `project_file`
// (any thread). `progress` gets 0..1 and returns false to cancel.
Status BuildProjectCloud(const std::string& project_file, const ProjectSession& session,
                         const std::function<bool(double)>& progress, ProjectCloudPtr* cloud);

class ProjectJobs : public QObject {
  Q_OBJECT
 public:
  explicit ProjectJobs(QObject* parent = nullptr) : QObject(parent) {}
  ~ProjectJobs() override;

  // The work gets the cancel flag and a progress function (thread-safe,
  // throttled to 2 % steps; fraction < 0: busy without a fraction) and
  // returns "" or why it failed; `done` runs on the GUI thread after it.
  // False if a job runs already.
  using Progress = std::function<void(const QString& what, double fraction)>;
  bool Run(const QString& what, std::function<QString(std::atomic<bool>*, const Progress&)> work,
           std::function<void(const QString& error)> done);
  void Cancel() { cancel_ = true; }
  bool running() const { return running_; }
  bool cancelled() const { return cancel_; }

 signals:
  void progress(const QString& what, double fraction);
  void finished(const QString& what, bool ok, const QString& message);

 private:
  std::unique_ptr<std::thread> thread_;
  std::atomic<bool> cancel_{false};
  bool running_ = false;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_JOBS_H_
