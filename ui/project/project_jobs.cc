#include "ui/project/project_jobs.h"

#include <QMetaObject>
#include <cstdio>
#include <filesystem>
#include <mutex>

#include "hardware/station/session_cloud.h"
#include "ui/project/project_detail.h"
#include "ui/workspace/background_priority.h"

namespace sweepscan::ui {

std::string CloudKey(const std::string& project_file, const ProjectSession& session) {
  std::string key = std::filesystem::absolute(ResolveSessionPath(project_file, session))
                        .lexically_normal()
                        .string();
  if (session.calibration) {
    char c[96];
    std::snprintf(c, sizeof(c), "|%.9g,%.9g,%.9g", session.calibration->alpha,
                  session.calibration->beta, session.calibration->gamma);
    key += c;
  }
  return key;
}

void IndexForPicks(ProjectCloud* cloud) {
  const std::vector<Eigen::Vector3f>& all = cloud->positions;
  cloud->bounds.setEmpty();
  cloud->block_bounds.assign((all.size() + ProjectCloud::kPickBlock - 1) / ProjectCloud::kPickBlock,
                             Eigen::AlignedBox3f());
  cloud->piece_bounds.assign((all.size() + ProjectCloud::kPickPiece - 1) / ProjectCloud::kPickPiece,
                             Eigen::AlignedBox3f());
  for (size_t i = 0; i < all.size(); ++i) {
    cloud->bounds.extend(all[i]);
    cloud->block_bounds[i / ProjectCloud::kPickBlock].extend(all[i]);
    cloud->piece_bounds[i / ProjectCloud::kPickPiece].extend(all[i]);
  }
  CountCubes(cloud);
}

bool IndexedForPicks(const ProjectCloud& cloud) {
  const size_t n = cloud.positions.size();
  return cloud.block_bounds.size() ==
             (n + ProjectCloud::kPickBlock - 1) / ProjectCloud::kPickBlock &&
         cloud.piece_bounds.size() ==
             (n + ProjectCloud::kPickPiece - 1) / ProjectCloud::kPickPiece &&
         cloud.piece_cubes.size() == cloud.piece_bounds.size();
}

Status BuildProjectCloud(const std::string& project_file, const ProjectSession& session,
                         const std::function<bool(double)>& progress, ProjectCloudPtr* cloud) {
  hardware::SessionCloudOptions options;
  options.progress = progress;
  hardware::SessionCloud built;
  auto out = std::make_shared<ProjectCloud>();
  const Status s =
      hardware::LoadSessionPositions(project_file, session, options, &built, &out->positions);
  if (!s.ok()) return s;
  out->id = session.id;
  out->key = CloudKey(project_file, session);
  IndexForPicks(out.get());
  out->damage = built.damage;
  out->has_truth = built.has_true_start;
  out->world_from_session_truth = built.world_from_session_truth;
  *cloud = std::move(out);
  return Status::Ok();
}

ProjectJobs::~ProjectJobs() {
  cancel_ = true;
  if (thread_ && thread_->joinable()) thread_->join();
}

bool ProjectJobs::Run(const QString& what,
                      std::function<QString(std::atomic<bool>*, const Progress&)> work,
                      std::function<void(const QString& error)> done) {
  if (running_) return false;
  if (thread_ && thread_->joinable()) thread_->join();  // The last one has finished.
  running_ = true;
  cancel_ = false;
  emit progress(what, 0.0);
  thread_ = std::make_unique<std::thread>([this, what, work = std::move(work),
                                           done = std::move(done)] {
    LowerThisThreadsPriority();
    // At most every 2 % (or on a new stage): the GUI thread is not flooded.
    auto last = std::make_shared<std::pair<QString, double>>(QString(), -1.0);
    auto mutex = std::make_shared<std::mutex>();
    const Progress report = [this, last, mutex](const QString& stage, double f) {
      {
        std::lock_guard<std::mutex> lock(*mutex);
        if (stage == last->first && f >= 0 && f - last->second < 0.02 && f < 1.0) return;
        *last = {stage, f};
      }
      QMetaObject::invokeMethod(this, [this, stage, f] { emit progress(stage, f); });
    };
    const QString error = work(&cancel_, report);
    QMetaObject::invokeMethod(this, [this, what, error, done] {
      running_ = false;
      done(error);
      emit finished(what, error.isEmpty(), error);
    });
  });
  return true;
}

}  // namespace sweepscan::ui
