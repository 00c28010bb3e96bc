#include "core/project/project_merge.h"

#include <algorithm>
#include <map>
#include <optional>

namespace sweepscan {
namespace {

// A session as the file holds it: two states are the same if they save the same.
std::string Saved(const ProjectSession& s) {
  Project one;
  one.sessions = {s};
  return ProjectToJson(one);
}

// Its placement alone: the pose and how it was found.
std::string Placement(const ProjectSession& s) {
  ProjectSession p;
  p.id = s.id;
  p.project_from_session = s.project_from_session;
  p.registration = s.registration;
  return Saved(p);
}

const ProjectSession* Find(const Project& p, const std::string& id) {
  const int i = p.Find(id);
  return i < 0 ? nullptr : &p.sessions[i];
}

bool Same(const ProjectSession* a, const ProjectSession* b) {
  if (a == nullptr || b == nullptr) return a == b;
  return Saved(*a) == Saved(*b);
}

bool PlacementChanged(const ProjectSession* was, const ProjectSession* now) {
  if (now == nullptr || !now->project_from_session) return false;  // nothing placed
  return was == nullptr || Placement(*was) != Placement(*now);
}

// A session's fields in the groups an edit changes together: its folder,
// its calibration, its placement (the pose and how it was found), shown or
// hidden, its colour.
constexpr int kFieldGroups = 5;

void CopyGroup(const ProjectSession& from, int group, ProjectSession* to) {
  switch (group) {
    case 0:
      to->path = from.path;
      to->recorded_utc = from.recorded_utc;  // which recording the folder holds
      break;
    case 1:
      to->calibration = from.calibration;
      break;
    case 2:
      to->project_from_session = from.project_from_session;
      to->registration = from.registration;
      break;
    case 3:
      to->visible = from.visible;
      break;
    default:
      to->color = from.color;
  }
}

// Group `group` of s alone, as the file would hold it.
std::string SavedGroup(const ProjectSession& s, int group) {
  ProjectSession only;
  only.id = s.id;
  CopyGroup(s, group, &only);
  return Saved(only);
}

// A session both sides edited, merged group by group: each group takes the
// side that changed it (a change of anchor in the file moves every
// placement, which must not clash with a colour set here). False when
// both changed one group differently.
bool MergeFields(const ProjectSession& base, const ProjectSession& here, const ProjectSession& file,
                 ProjectSession* merged) {
  *merged = base;
  for (int g = 0; g < kFieldGroups; ++g) {
    const std::string b = SavedGroup(base, g), h = SavedGroup(here, g), f = SavedGroup(file, g);
    if (h != b && f != b && h != f) return false;
    CopyGroup(h != b ? here : file, g, merged);
  }
  return true;
}

// What one side did to a session, for the conflict's message.
std::string Change(const ProjectSession* was, const ProjectSession* now) {
  if (was == nullptr) return "added";
  if (now == nullptr) return "removed";
  std::vector<std::string> what;
  if (was->path != now->path || was->recorded_utc != now->recorded_utc) what.push_back("its folder");
  ProjectSession a = *was, b = *now;
  a.project_from_session.reset(), b.project_from_session.reset();
  a.registration = b.registration = RegistrationEvidence();
  a.visible = b.visible = true;
  a.color = b.color = "";
  a.path = b.path = "";
  a.recorded_utc = b.recorded_utc = "";
  if (Saved(a) != Saved(b)) what.push_back("its calibration");
  if (Placement(*was) != Placement(*now)) {
    what.push_back(now->project_from_session ? "placed again (" + now->registration.method + ")"
                                             : "its placement removed");
  }
  if (was->visible != now->visible) what.push_back(now->visible ? "shown" : "hidden");
  if (was->color != now->color) what.push_back("its colour");
  std::string text;
  for (const std::string& w : what) text += (text.empty() ? "" : ", ") + w;
  return text;
}

std::string AnchorId(const Project& p) {
  const int a = p.Anchor();
  return a < 0 ? std::string() : p.sessions[a].id;
}

bool SameRelative(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation() - b.translation()).norm() < 1e-9 &&
         a.rotation().angularDistance(b.rotation()) < 1e-9;
}

}  // namespace

ProjectMerge MergeProjects(const Project& base, const Project& here, const Project& file) {
  ProjectMerge m;
  std::map<std::string, std::string> why;        // by id, the conflicts
  std::map<std::string, const Project*> source;  // the side each merged session comes from
  const auto conflict = [&](const std::string& id, const std::string& text) {
    if (why.count(id) == 0) why[id] = text;
  };

  // The project's own fields.
  const auto field = [&](const std::string& name, const std::string& b, const std::string& h,
                         const std::string& f, std::string* out) {
    *out = h != b ? h : f;
    if (h != b && f != b && h != f)
      conflict("the project's " + name, "changed here and in the file");
  };
  field("name", base.name, here.name, file.name, &m.merged.name);
  field("description", base.description, here.description, file.description, &m.merged.description);

  // The file's order, then what was added here.
  std::vector<std::string> ids;
  for (const ProjectSession& s : file.sessions) ids.push_back(s.id);
  for (const ProjectSession& s : here.sessions) {
    if (Find(file, s.id) == nullptr) ids.push_back(s.id);
  }
  for (const std::string& id : ids) {
    const ProjectSession* b = Find(base, id);
    const ProjectSession* h = Find(here, id);
    const ProjectSession* f = Find(file, id);
    const bool here_changed = !Same(b, h), file_changed = !Same(b, f);
    ProjectSession fields;
    if (here_changed && file_changed && b != nullptr && h != nullptr && f != nullptr &&
        MergeFields(*b, *h, *f, &fields)) {
      // Edited on both sides, in different fields.
      m.from_file.push_back(id);
      m.merged.sessions.push_back(fields);
      source[id] = SavedGroup(*h, 2) != SavedGroup(*b, 2) ? &here : &file;  // the placement's
      continue;
    }
    const ProjectSession* take = here_changed ? h : f;
    if (here_changed && file_changed && !Same(h, f)) {
      conflict(id, Change(b, h) + " here, " + Change(b, f) + " in the file");
    } else if (!here_changed && file_changed) {
      m.from_file.push_back(id);
    }
    if (take == nullptr) continue;
    m.merged.sessions.push_back(*take);
    source[id] = take == h ? &here : &file;
  }

  // A placement made on one side is in that side's frame: if the other
  // changed the anchor, the frames differ.
  const std::string anchor_base = AnchorId(base), anchor_here = AnchorId(here),
                    anchor_file = AnchorId(file);
  if (anchor_here != anchor_file) {
    for (const ProjectSession& s : m.merged.sessions) {
      const Project* side = source[s.id];
      const Project* other = side == &here ? &file : &here;
      const std::string& anchor_other = side == &here ? anchor_file : anchor_here;
      if (anchor_other != anchor_base && PlacementChanged(Find(base, s.id), &s)) {
        conflict(s.id, std::string("placed ") + (side == &here ? "here" : "in the file") +
                           " while the anchor became '" + anchor_other + "' " +
                           (other == &here ? "here" : "in the file"));
      }
    }
  }
  // Each placement against a reference as measured: the reference where
  // that side had it.
  for (const ProjectSession& s : m.merged.sessions) {
    const std::string& r = s.registration.reference;
    if (!s.project_from_session || r.empty()) continue;
    const Project* side = source[s.id];
    const char* there = side == &here ? "in the file" : "here";
    const ProjectSession* ref = Find(m.merged, r);
    const ProjectSession* ref_side = Find(*side, r);
    if (ref == nullptr || !ref->project_from_session) {
      conflict(s.id, "placed against '" + r + "', " + (ref == nullptr ? "removed " : "unplaced ") +
                         there);
    } else if (ref_side != nullptr && ref_side->project_from_session &&
               !SameRelative(ref->project_from_session->inverse() * *s.project_from_session,
                             ref_side->project_from_session->inverse() * *s.project_from_session)) {
      conflict(s.id, "placed against '" + r + "', placed again " + std::string(there));
    }
  }

  // In the merge's order, the project's own fields first.
  for (const char* f : {"the project's name", "the project's description"}) {
    if (why.count(f) != 0) m.conflicts.push_back(std::string(f) + ": " + why[f]);
  }
  for (const ProjectSession& s : m.merged.sessions) {
    if (why.count(s.id) == 0) continue;
    m.conflicts.push_back("'" + s.id + "': " + why[s.id]);
    m.conflicting.push_back(s.id);
  }
  // A session removed here that the file changed (not in the merge).
  for (const auto& [id, text] : why) {
    if (Find(m.merged, id) == nullptr && id.rfind("the project's ", 0) != 0) {
      m.conflicts.push_back("'" + id + "': " + text);
      m.conflicting.push_back(id);
    }
  }
  // Each side loads, and so must what is written of both: two sessions
  // moved onto one folder, one on each side, merge without a conflict of
  // fields but make a file the loader refuses.
  if (m.conflicts.empty()) {
    Project check;
    const Status loads = ProjectFromJson(ProjectToJson(m.merged), "the merge", &check);
    if (!loads.ok()) m.conflicts.push_back(loads.message() + " (from the edits here and in the file together)");
  }
  return m;
}

}  // namespace sweepscan
