// The pieces of `sweepscan-cli project` shared by its files.
#ifndef SWEEPSCAN_APP_CLI_PROJECT_H_
#define SWEEPSCAN_APP_CLI_PROJECT_H_

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "app/cli_args.h"
#include "hardware/station/session_cloud.h"

namespace sweepscan::app {

int RunProjectAlign(const Args& args);   // cli_project_align.cc
int RunProjectExport(const Args& args);  // cli_project_export.cc

// Session clouds of one project, each built once per command, with the
// command's --strict and --pose-source; warnings (damaged records) on stderr.
class SessionClouds {
 public:
  SessionClouds(std::string project_file, hardware::SessionCloudOptions options)
      : file_(std::move(project_file)), options_(std::move(options)) {}
  // A session's cloud as registration takes it: its positions (12 bytes a
  // point, streamed from frames.bin: hardware::LoadSessionPositions), with
  // what it was built from (`info`, whose points stay empty).
  struct Cloud {
    hardware::SessionCloud info;
    std::vector<Eigen::Vector3f> positions;
  };
  // Null with *error set on failure.
  const Cloud* Get(const ProjectSession& session, std::string* error);
  void Drop(const std::string& id) { clouds_.erase(id); }

 private:
  std::string file_;
  hardware::SessionCloudOptions options_;
  std::map<std::string, Cloud> clouds_;
  std::map<std::string, std::string> failed_;  // id -> why its cloud could not be built
};

// The placed, visible sessions' points (or --sessions ID,ID's) in the
// project frame, one session built at a time (cli_project_export.cc): what
// `plan PROJECT` draws. kExitOk or an exit code after one error line.
int ProjectPositions(const Args& args, const std::string& project_file, std::vector<Eigen::Vector3f>* points);

// LoadProject with its repairs (a reference loop an older sweepscan saved,
// core/project/project.h) said on stderr as warnings; `text` (optional):
// the file's bytes as read, to tell later whether another program saved it.
Status LoadProjectAndSay(const std::string& file, Project* project, std::string* text = nullptr);
// The file's bytes; false if it cannot be read.
bool ReadProjectFile(const std::string& file, std::string* text);
// Whether `path` (relative to the project file's folder) is a session
// folder: one with a meta.json, as the app requires.
// `recorded_utc` (optional): its meta.json's created_utc (ProjectSession::recorded_utc).
Status CheckSessionFolder(const std::string& project_file, const std::string& path,
                          std::string* recorded_utc = nullptr);
// Warns on stderr about the sessions in `chosen` whose placement was
// measured with other poses than `source`, the clouds are drawn with.
void WarnPoseSource(const Project& project, const std::vector<size_t>& chosen, PoseSource source);

// --strict and --pose-source; kExitOk or an exit code after one error line.
int SessionCloudOptionsFromArgs(const Args& args, hardware::SessionCloudOptions* options);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_CLI_PROJECT_H_
