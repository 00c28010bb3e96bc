#include "ui/workspace/cloud_export.h"

#include "core/cloud/cloud_io.h"
#include "core/cloud/las_writer.h"
#include "core/common/file_suffix.h"

namespace sweepscan {

Status ExportCloudFile(const std::string& path, const CloudSnapshotRef& cloud,
                       const std::string& session_dir, const SessionMeta& fallback,
                       const std::atomic<bool>* cancel, std::string* note) {
  if (note != nullptr) note->clear();
  if (!HasFileSuffix(path, ".las")) return SaveCloud(path, cloud, cancel);
  SessionMeta meta = fallback;
  if (!session_dir.empty()) {
    SessionMeta read;
    if (ReadSessionMeta(session_dir + "/" + kSessionMetaFile, &read).ok()) meta = read;
  }
  LasWriterOptions options;
  options.system_identifier = SessionSystemIdentifier(meta);
  options.generating_software = "sweepscan 0.1.0";
  std::string time_note;
  const Status s = SaveLas(path, cloud, meta.created_utc, options, cancel, nullptr, &time_note);
  if (s.ok() && note != nullptr && !time_note.empty()) *note = time_note;
  return s;
}

}  // namespace sweepscan
