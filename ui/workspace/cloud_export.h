// The app's cloud written to a file, chosen by its suffix: LAS 1.4
// (docs/las-format.md) with the session's clock and hardware in its header,
// or PLY / PCD (docs/cloud-format.md). Shared by File > Export Cloud and the
// command line's --export-cloud, so both write what `sweepscan-cli
// reconstruct --out` writes for the same suffix.
//
// Threading: any thread (a job's); reads only the snapshot and meta.json.
#ifndef SWEEPSCAN_UI_WORKSPACE_CLOUD_EXPORT_H_
#define SWEEPSCAN_UI_WORKSPACE_CLOUD_EXPORT_H_

#include <atomic>
#include <string>

#include "core/cloud/cloud.h"
#include "core/common/status.h"
#include "core/session/session.h"

namespace sweepscan {

// `session_dir` is the shown session's folder ("" for none): its meta.json's
// created_utc anchors LAS's GPS time and its link names the System
// Identifier. Without a readable meta.json, `fallback` (the live link's meta)
// is used. *note gets what the operator should know of a file that was
// written (its times are robot seconds, and why); "" otherwise.
Status ExportCloudFile(const std::string& path, const CloudSnapshotRef& cloud,
                       const std::string& session_dir, const SessionMeta& fallback,
                       const std::atomic<bool>* cancel, std::string* note);

}  // namespace sweepscan

#endif  // SWEEPSCAN_UI_WORKSPACE_CLOUD_EXPORT_H_
