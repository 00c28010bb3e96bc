#include "ui/project/project_layer.h"

#include <vtkActor.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkLookupTable.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkTypeInt32Array.h>
#include <vtkUnsignedCharArray.h>

#include <QColor>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include "core/geometry/ray_box.h"
#include "ui/project/project_detail.h"
#include "ui/view/cloud_view.h"
#include "ui/view/paced_mapper.h"
#include "ui/workspace/background_priority.h"

namespace sweepscan::ui {
namespace {

constexpr int kSlots = 256;

vtkSmartPointer<vtkMatrix4x4> Matrix(const Rigid3d& t) {
  auto m = vtkSmartPointer<vtkMatrix4x4>::New();
  const Eigen::Matrix4d e = t.ToIsometry().matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m->SetElement(r, c, e(r, c));
  }
  return m;
}

// Points `xyz` as vertices carrying the slot byte of their session (the
// shared lookup table's entry): VTK data only, no mapper, so any thread.
vtkSmartPointer<vtkPolyData> SlotPoly(const vtkSmartPointer<vtkFloatArray>& xyz, int slot_value) {
  const size_t m = static_cast<size_t>(xyz->GetNumberOfTuples());
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(xyz);
  auto offsets = vtkSmartPointer<vtkTypeInt32Array>::New();
  offsets->SetNumberOfValues(static_cast<vtkIdType>(m + 1));
  auto connectivity = vtkSmartPointer<vtkTypeInt32Array>::New();
  connectivity->SetNumberOfValues(static_cast<vtkIdType>(m));
  for (size_t k = 0; k <= m; ++k)
    offsets->SetValue(static_cast<vtkIdType>(k), static_cast<int32_t>(k));
  for (size_t k = 0; k < m; ++k)
    connectivity->SetValue(static_cast<vtkIdType>(k), static_cast<int32_t>(k));
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  verts->SetData(offsets, connectivity);
  auto slot = vtkSmartPointer<vtkUnsignedCharArray>::New();
  slot->SetName("session");
  slot->SetNumberOfValues(static_cast<vtkIdType>(m));
  std::fill_n(slot->GetPointer(0), m, static_cast<unsigned char>(slot_value));
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetVerts(verts);
  poly->GetPointData()->SetScalars(slot);
  return poly;
}

bool SameMatrix(vtkMatrix4x4* a, vtkMatrix4x4* b) {
  if (a == nullptr || b == nullptr) return false;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (a->GetElement(r, c) != b->GetElement(r, c)) return false;
    }
  }
  return true;
}

}  // namespace

ProjectLayer::ProjectLayer(CloudView* view) : view_(view) {
  lut_ = vtkSmartPointer<vtkLookupTable>::New();
  lut_->SetNumberOfTableValues(kSlots);
  lut_->SetTableRange(0, kSlots - 1);
  for (int i = 0; i < kSlots; ++i) lut_->SetTableValue(i, 0.5, 0.5, 0.5, 1.0);
  view_->SetLayerPicker([this] { return PickSnapshot(); });
  empty_ = vtkSmartPointer<PacedMapper>::New();
  empty_->SetInputData(vtkSmartPointer<vtkPolyData>::New());
  planned_ = QObject::connect(view_, &CloudView::restPlanned, view_, [this] { PlanDetail(); });
}

ProjectLayer::~ProjectLayer() {
  QObject::disconnect(planned_);
  alive_.reset();  // A plan's result queued after this finds nobody.
  if (detail_thread_) detail_thread_->join();
  view_->SetLayerPicker(nullptr);
  Clear();
}

void ProjectLayer::Remove(Entry* e) {
  view_->InvalidatePicks();  // A pick in flight may have found its points.
  DropDetail(e);
  for (auto& actor : e->pieces) view_->RemoveLayer(actor);
  e->pieces.clear();
  e->piece_rest.clear();
  e->piece_motion.clear();
}

void ProjectLayer::DropDetail(Entry* e) {
  if (!e->detailed) return;
  for (auto& actor : e->detail) view_->RemoveLayer(actor);
  e->detail.clear();
  e->detail_rest.clear();
  e->detail_points = 0;
  e->detailed = false;
  std::vector<std::pair<vtkActor*, vtkPolyDataMapper*>> rests;
  for (size_t k = 0; k < e->pieces.size(); ++k) rests.emplace_back(e->pieces[k], e->piece_rest[k]);
  view_->SetLayerRests(rests);
}

// A plan's result: each thinned session's points at rest, as polydata of a
// rest batch's size at most (the view's progressive passes draw one at a
// time, nearest first), built on the plan's thread.
struct ProjectLayer::DetailResult {
  struct Session {
    std::string id;
    ProjectCloudPtr cloud;  // the cloud planned (a rebuilt one is another)
    std::vector<vtkSmartPointer<vtkPolyData>> polys;
    size_t points = 0;
  };
  std::vector<Session> sessions;
};

void ProjectLayer::PlanDetail() {
  // The sessions thinned at rest; the others draw every point already.
  std::vector<DetailSession> sessions;
  auto result = std::make_shared<DetailResult>();
  std::vector<int> slot_values;
  size_t whole = 0;
  // What the plan depends on: the sessions (each cloud, pose and slot), the
  // budget, and the camera and clip (CloudView::CameraKey, compared as the
  // view compares them: the frustum planes themselves change in their last
  // bits with each frame's clipping range). The view plans its rest level
  // more often than they change (every return to rest): the same plan is
  // not made twice, nor shown over itself.
  DetailKey key;
  for (auto& [id, e] : entries_) {
    if (!e.visible) continue;
    if (e.stride > 1 && IndexedForPicks(*e.cloud)) {
      sessions.push_back({e.cloud.get(), e.pose});
      result->sessions.push_back({id, e.cloud, {}, 0});
      slot_values.push_back(e.slot);
      const Eigen::Vector4d q = e.pose.rotation().coeffs();
      const Eigen::Vector3d t = e.pose.translation();
      key.sessions.insert(key.sessions.end(),
                          {static_cast<double>(reinterpret_cast<uintptr_t>(e.cloud.get())), q[0],
                           q[1], q[2], q[3], t[0], t[1], t[2], static_cast<double>(e.slot)});
    } else {
      // Every point, or (no index to plan with) every k-th.
      whole += (e.cloud->positions.size() + e.stride - 1) / e.stride;
    }
  }
  DetailCamera camera;
  view_->ViewFrustum(camera.planes.data(), camera.eye.data());
  camera.clip_z = view_->clip_height();
  // The rest budget less what is drawn beside the detail: the sessions
  // drawn whole and the thinned ones' motion level (within the LOD budget).
  const size_t rest = view_->rest_budget();
  const size_t budget = rest - std::min(rest / 2, whole + view_->lod_budget());
  key.camera = view_->CurrentCameraKey();
  key.budget = budget;
  if (planned_key_ && key.sessions == planned_key_->sessions &&
      key.budget == planned_key_->budget &&
      CloudView::SameCamera(key.camera, planned_key_->camera)) {
    return;  // Planned for this already (or being planned).
  }
  if (detail_thread_) {
    detail_wanted_ = true;  // Planned again when the running plan ends.
    return;
  }
  planned_key_ = key;
  if (sessions.empty()) {
    for (auto& [id, e] : entries_) DropDetail(&e);
    return;
  }
  // Off the GUI thread: 70-120 ms for a 99.5 M-point session on it (the
  // pieces in view, then the points copied). The clouds are immutable and
  // held by the result.
  std::weak_ptr<bool> alive = alive_;
  detail_thread_ =
      std::make_unique<std::thread>([this, alive, sessions, camera, budget, slot_values, result] {
        LowerThisThreadsPriority();  // As the jobs': the GUI and the renderer first.
        const std::vector<std::vector<uint32_t>> planned = ui::PlanDetail(sessions, camera, budget);
        for (size_t s = 0; s < planned.size(); ++s) {
          const std::vector<Eigen::Vector3f>& all = sessions[s].cloud->positions;
          const std::vector<uint32_t>& indices = planned[s];
          // In actors of the view's rest batch size: a progressive pass draws
          // one, its upload included, within about 30 ms (65 536 points took
          // 34-42 ms).
          constexpr size_t kBatch = CloudView::kRestBatchPoints;
          for (size_t first = 0; first < indices.size(); first += kBatch) {
            const size_t count = std::min(kBatch, indices.size() - first);
            auto xyz = vtkSmartPointer<vtkFloatArray>::New();
            xyz->SetNumberOfComponents(3);
            xyz->SetNumberOfTuples(static_cast<vtkIdType>(count));
            float* out = xyz->GetPointer(0);
            for (size_t k = 0; k < count; ++k) {
              const Eigen::Vector3f& p = all[indices[first + k]];
              out[3 * k] = p.x();
              out[3 * k + 1] = p.y();
              out[3 * k + 2] = p.z();
            }
            result->sessions[s].polys.push_back(SlotPoly(xyz, slot_values[s]));
          }
          result->sessions[s].points = indices.size();
        }
        QMetaObject::invokeMethod(
            view_,
            [this, alive, result] {
              if (alive.lock()) FinishDetail(*result);
            },
            Qt::QueuedConnection);
      });
}

void ProjectLayer::FinishDetail(const DetailResult& result) {
  detail_thread_->join();
  detail_thread_.reset();
  if (!detail_wanted_) {
    ApplyDetail(result);
    return;
  }
  // The camera or the sessions changed while it ran: the plan for them,
  // not this one, is shown (made again even if they came back to what this
  // one was for: its result is gone).
  detail_wanted_ = false;
  planned_key_.reset();
  PlanDetail();
}

void ProjectLayer::ApplyDetail(const DetailResult& result) {
  for (auto& [id, e] : entries_) DropDetail(&e);
  std::vector<std::pair<vtkActor*, vtkPolyDataMapper*>> rests;
  for (const DetailResult::Session& planned : result.sessions) {
    const auto it = entries_.find(planned.id);
    if (it == entries_.end() || it->second.cloud != planned.cloud) continue;
    Entry* e = &it->second;
    for (const vtkSmartPointer<vtkPolyData>& poly : planned.polys) {
      vtkSmartPointer<vtkPolyDataMapper> mapper = SlotMapper(poly);
      vtkSmartPointer<vtkActor> actor = EntryActor(*e, mapper);
      view_->AddLayer(actor, empty_);
      e->detail.push_back(actor);
      e->detail_rest.push_back(mapper);
    }
    e->detail_points = planned.points;
    e->detailed = true;  // Even with no point in view: its pieces draw their motion level.
    for (size_t k = 0; k < e->pieces.size(); ++k) {
      if (e->piece_motion[k]) rests.emplace_back(e->pieces[k], e->piece_motion[k]);
    }
  }
  view_->SetLayerRests(rests);
}

bool ProjectLayer::detail_pending() const { return detail_thread_ != nullptr || detail_wanted_; }

std::vector<Eigen::Vector3d> ProjectLayer::DetailPoints() const {
  std::vector<Eigen::Vector3d> out;
  for (const auto& [id, e] : entries_) {
    if (!e.visible) continue;
    for (const auto& mapper : e.detail_rest) {
      vtkPoints* points = mapper->GetInput()->GetPoints();
      for (vtkIdType i = 0; i < points->GetNumberOfPoints(); ++i) {
        double p[3];
        points->GetPoint(i, p);
        out.push_back(e.pose * Eigen::Vector3d(p[0], p[1], p[2]));
      }
    }
  }
  return out;
}

Eigen::AlignedBox3d ProjectLayer::drawn_bounds() const {
  Eigen::AlignedBox3d box;
  for (const auto& [id, e] : entries_) {
    if (!e.visible || e.cloud->bounds.isEmpty()) continue;
    const Eigen::AlignedBox3d b = e.cloud->bounds.cast<double>();
    for (int k = 0; k < 8; ++k) box.extend(e.pose * b.corner(Eigen::AlignedBox3d::CornerType(k)));
  }
  return box;
}

size_t ProjectLayer::PointsNear(const Eigen::Vector3d& c, double r) const {
  size_t n = 0;
  for (const auto& [id, e] : entries_) {
    if (!e.visible) continue;
    const Eigen::Vector3f local = (e.pose.inverse() * c).cast<float>();
    const float r2 = static_cast<float>(r * r);
    for (const Eigen::Vector3f& p : e.cloud->positions) n += (p - local).squaredNorm() < r2;
  }
  return n;
}

size_t ProjectLayer::detail_points() const {
  size_t n = 0;
  for (const auto& [id, e] : entries_) n += e.visible ? e.detail_points : 0;
  return n;
}

void ProjectLayer::Clear() {
  for (auto& [id, e] : entries_) Remove(&e);
  entries_.clear();
  planned_key_.reset();  // Its clouds' addresses may be new clouds' next.
}

int ProjectLayer::FreeSlot() const {
  std::set<int> used;
  for (const auto& [id, e] : entries_) used.insert(e.slot);
  for (int s = 0; s < kSlots; ++s) {
    if (used.count(s) == 0) return s;
  }
  return kSlots - 1;  // More sessions than slots shown at once: they share the last colour.
}

ProjectLayer::Entry ProjectLayer::NewEntry(const ProjectCloudPtr& cloud, size_t sessions) const {
  Entry e;
  e.cloud = cloud;
  e.slot = FreeSlot();
  // Every k-th point above this session's share of the rest budget.
  const size_t n = cloud->positions.size();
  const size_t share = std::max<size_t>(1, view_->rest_budget() / std::max<size_t>(1, sessions));
  e.stride = std::max<size_t>(1, (n + share - 1) / share);
  const size_t motion_share = std::max<size_t>(1, view_->lod_budget() / std::max<size_t>(1, sessions));
  const size_t motion = std::max<size_t>(1, (n + motion_share - 1) / motion_share);
  e.motion_stride = e.stride * std::max<size_t>(1, (motion + e.stride - 1) / e.stride);
  return e;
}

vtkSmartPointer<vtkPolyDataMapper> ProjectLayer::PieceMapper(const Entry& e, size_t first,
                                                             size_t last, size_t step) const {
  const std::vector<Eigen::Vector3f>& all = e.cloud->positions;
  const size_t m = (last - first + step - 1) / step;
  auto xyz = vtkSmartPointer<vtkFloatArray>::New();
  xyz->SetNumberOfComponents(3);
  if (step == 1) {
    // In place: the positions outlive the actor (the entry holds both), and
    // save = 1 tells VTK not to free them.
    xyz->SetArray(const_cast<float*>(all[first].data()), static_cast<vtkIdType>(3 * m), 1);
  } else {
    xyz->SetNumberOfTuples(static_cast<vtkIdType>(m));
    float* out = xyz->GetPointer(0);
    for (size_t k = 0; k < m; ++k) {
      const Eigen::Vector3f& p = all[first + k * step];
      out[3 * k] = p.x();
      out[3 * k + 1] = p.y();
      out[3 * k + 2] = p.z();
    }
  }
  return SlotMapper(SlotPoly(xyz, e.slot));
}

vtkSmartPointer<vtkActor> ProjectLayer::EntryActor(const Entry& e,
                                                   vtkPolyDataMapper* mapper) const {
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  actor->GetProperty()->SetRepresentationToPoints();
  actor->PickableOff();
  actor->SetVisibility(e.visible);
  if (e.matrix) actor->SetUserMatrix(e.matrix);
  return actor;
}

vtkSmartPointer<vtkPolyDataMapper> ProjectLayer::SlotMapper(
    const vtkSmartPointer<vtkPolyData>& poly) const {
  // Paced by the view it is drawn in, as the cloud's mappers are
  // (CloudView::AddLayer; ui/view/paced_mapper.h): unpaced, llvmpipe's
  // binned scenes after frames of the office floor's 567 000 points kept
  // the app about 90 MiB larger for as long as it ran.
  auto mapper = vtkSmartPointer<PacedMapper>::New();
  mapper->SetInputData(poly);
  mapper->SetLookupTable(lut_);
  mapper->SetColorModeToMapScalars();  // Bytes are slots, not colours.
  mapper->SetScalarModeToUsePointData();
  mapper->SetScalarRange(0, kSlots - 1);
  mapper->ScalarVisibilityOn();
  return mapper;
}

void ProjectLayer::AddPiece(Entry* e) {
  const size_t first = e->next;
  const size_t last = std::min(e->cloud->positions.size(), first + kPiecePoints * e->stride);
  e->next = last;
  vtkSmartPointer<vtkPolyDataMapper> rest = PieceMapper(*e, first, last, e->stride);
  // The motion level's points are among the drawn ones (first is a
  // multiple of stride past the session's start, motion_stride of stride),
  // so the progressive passes draw them again where they already are.
  vtkSmartPointer<vtkPolyDataMapper> motion =
      e->motion_stride > e->stride ? PieceMapper(*e, first, last, e->motion_stride) : nullptr;
  vtkSmartPointer<vtkActor> actor = EntryActor(*e, rest);
  view_->AddLayer(actor, motion);
  // Beside a detail the piece draws its motion level at rest too.
  if (e->detailed && motion) view_->SetLayerRests({{actor, motion}});
  e->pieces.push_back(actor);
  e->piece_rest.push_back(rest);
  e->piece_motion.push_back(motion);
  e->drawn += static_cast<size_t>(rest->GetInput()->GetNumberOfPoints());
}

bool ProjectLayer::Pump() {
  int budget = kPiecesPerPump;
  for (auto& [id, e] : entries_) {
    // Hidden sessions wait until shown: no upload for nothing.
    while (budget > 0 && e.visible && e.next < e.cloud->positions.size()) {
      AddPiece(&e);
      --budget;
    }
  }
  return pending();
}

bool ProjectLayer::pending() const {
  for (const auto& [id, e] : entries_) {
    if (e.visible && e.next < e.cloud->positions.size()) return true;
  }
  return false;
}

void ProjectLayer::Sync(const Project& project,
                        const std::map<std::string, ProjectCloudPtr>& clouds) {
  bool changed = false;
  // Gone from the project, or built again (another folder or calibration).
  for (auto it = entries_.begin(); it != entries_.end();) {
    const int i = project.Find(it->first);
    const auto c = clouds.find(it->first);
    if (i < 0 || c == clouds.end() || c->second != it->second.cloud) {
      Remove(&it->second);
      it = entries_.erase(it);
      changed = true;
    } else {
      ++it;
    }
  }
  for (const ProjectSession& s : project.sessions) {
    const auto c = clouds.find(s.id);
    auto it = entries_.find(s.id);
    const bool shown = s.project_from_session.has_value() && s.visible;
    if (it == entries_.end()) {
      if (!shown || c == clouds.end()) continue;  // Built when first shown.
      it = entries_.emplace(s.id, NewEntry(c->second, project.sessions.size())).first;
    }
    Entry& e = it->second;
    if (e.visible != shown) {
      if (!shown) view_->InvalidatePicks();
      e.visible = shown;
      for (auto& actor : e.pieces) actor->SetVisibility(shown);
      for (auto& actor : e.detail) actor->SetVisibility(shown);
      changed = true;
    }
    if (s.project_from_session) {
      auto m = Matrix(*s.project_from_session);
      if (!SameMatrix(m, e.matrix)) {
        view_->InvalidatePicks();  // A pick in flight placed its point at the old pose.
        e.matrix = m;
        e.pose = *s.project_from_session;
        for (auto& actor : e.pieces) actor->SetUserMatrix(m);
        for (auto& actor : e.detail) actor->SetUserMatrix(m);
        changed = true;
      }
    }
    const QColor color(QString::fromStdString(s.color));
    double old[4];
    lut_->GetTableValue(e.slot, old);
    if (color.isValid() && (old[0] != color.redF() || old[1] != color.greenF() ||
                            old[2] != color.blueF())) {
      lut_->SetTableValue(e.slot, color.redF(), color.greenF(), color.blueF(), 1.0);
      lut_->Modified();
      changed = true;
    }
  }
  if (changed) {
    PlanDetail();  // What is shown changed under a still camera.
    view_->RequestRender();
  }
}

std::vector<std::string> ProjectLayer::drawn_sessions() const {
  std::vector<std::string> ids;
  for (const auto& [id, e] : entries_) {
    if (e.visible && !e.pieces.empty()) ids.push_back(id);
  }
  return ids;
}

size_t ProjectLayer::drawn_points() const {
  size_t n = 0;
  for (const auto& [id, e] : entries_) n += e.visible ? e.drawn : 0;
  return n;
}

size_t ProjectLayer::shown_points() const {
  size_t n = 0;
  for (const auto& [id, e] : entries_) {
    if (e.visible && !e.pieces.empty()) n += e.cloud->positions.size();
  }
  return n;
}

bool ProjectLayer::drawn_pose(const std::string& id, Rigid3d* project_from_session) const {
  const auto it = entries_.find(id);
  if (it == entries_.end() || !it->second.visible || it->second.pieces.empty()) return false;
  *project_from_session = it->second.pose;
  return true;
}

namespace {

// Whether a point of `box` can lie within the pick's tolerance of the ray
// o + t d (|d| = 1), 0 < t < max_t, and where the ray enters the box grown
// by the tolerance at its far side (tolerance_per_t times the farthest t it
// can have; slabs).
bool RayNearBox(const RaySlabs& slabs, const Eigen::Vector3d& o, const Eigen::AlignedBox3f& box,
                double tolerance_per_t, double max_t, double* enter) {
  if (box.isEmpty()) return false;
  const double b[6] = {box.min().x(), box.max().x(), box.min().y(),
                       box.max().y(), box.min().z(), box.max().z()};
  const Eigen::Vector3d lo(b[0], b[2], b[4]), hi(b[1], b[3], b[5]);
  const double far = (0.5 * (lo + hi) - o).norm() + 0.5 * (hi - lo).norm();
  return slabs.Hits(b, tolerance_per_t * std::min(far, max_t), max_t, enter);
}

}  // namespace

bool ProjectLayer::Pick(const CloudView::PickRay& ray, double* best_t, PickHit* hit) const {
  return PickSnapshot()(ray, best_t, hit);
}

LayerPick ProjectLayer::PickSnapshot() const {
  // What a pick reads, as it is now: the clouds are shared and never
  // change (a rebuilt one is another), the poses and counts are copied.
  struct Target {
    std::string id;
    Rigid3d pose;
    ProjectCloudPtr cloud;
    size_t uploaded;
  };
  std::vector<Target> targets;
  for (const auto& [id, e] : entries_) {
    if (!e.visible || e.pieces.empty()) continue;
    targets.push_back({id, e.pose, e.cloud, std::min(e.next, e.cloud->positions.size())});
  }
  return [targets = std::move(targets)](const PickRay& ray, double* best_t, PickHit* hit) {
    bool found = false;
    for (const Target& e : targets) {
      // The ray in the session's frame (a rigid motion keeps t and the
      // distances to the ray); the clip stays in the project's frame.
      const Eigen::Matrix3d r = e.pose.rotation().toRotationMatrix();
      const Eigen::Vector3d t = e.pose.translation();
      const Eigen::Vector3d o = r.transpose() * (ray.origin - t);
      const Eigen::Vector3d d = r.transpose() * ray.direction;
      const Eigen::Vector3d z_row = r.row(2).transpose();
      const RaySlabs slabs(o, d);
      const std::vector<Eigen::Vector3f>& all = e.cloud->positions;
      const std::vector<Eigen::AlignedBox3f>& blocks = e.cloud->block_bounds;
      const std::vector<Eigen::AlignedBox3f>& pieces = e.cloud->piece_bounds;
      // Every point uploaded so far (the drawn pieces hold every k-th of
      // them): the pick pieces the ray passes near in the blocks it meets,
      // nearest entry first, until one enters beyond the point found (a
      // point within the tolerance lies inside its piece's grown box, so the
      // ray is in that box before the point).
      std::vector<std::pair<double, size_t>> met;  // (entry, piece)
      const size_t uploaded = e.uploaded;
      const bool indexed = IndexedForPicks(*e.cloud);
      if (!indexed) {  // No boxes: every piece, entered at the eye.
        for (size_t p = 0; p * ProjectCloud::kPickPiece < uploaded; ++p) met.emplace_back(0.0, p);
      }
      for (size_t b = 0; indexed && b * ProjectCloud::kPickBlock < uploaded && b < blocks.size();
           ++b) {
        double enter = 0.0;
        if (!RayNearBox(slabs, o, blocks[b], ray.tolerance_per_t, *best_t, &enter)) continue;
        const size_t p0 = b * (ProjectCloud::kPickBlock / ProjectCloud::kPickPiece);
        const size_t p1 =
            std::min(pieces.size(), p0 + ProjectCloud::kPickBlock / ProjectCloud::kPickPiece);
        for (size_t p = p0; p < p1 && p * ProjectCloud::kPickPiece < uploaded; ++p) {
          if (RayNearBox(slabs, o, pieces[p], ray.tolerance_per_t, *best_t, &enter))
            met.emplace_back(enter, p);
        }
      }
      std::sort(met.begin(), met.end());
      for (const auto& [enter, p] : met) {
        if (enter >= *best_t) break;
        const size_t end = std::min(uploaded, (p + 1) * ProjectCloud::kPickPiece);
        for (size_t i = p * ProjectCloud::kPickPiece; i < end; ++i) {
          const Eigen::Vector3d q = all[i].cast<double>();
          if (z_row.dot(q) + t.z() > ray.clip_z) continue;  // Clipped: not pickable.
          const Eigen::Vector3d v = q - o;
          const double along = v.dot(d);
          if (along <= 0 || along >= *best_t) continue;
          const double tol = ray.tolerance_per_t * along;
          if (v.squaredNorm() - along * along <= tol * tol) {
            *best_t = along;
            hit->layer = QString::fromStdString(e.id);
            hit->local = q;
            hit->world = e.pose * q;
            found = true;
          }
        }
      }
    }
    return found;
  };
}

QColor ProjectLayer::drawn_color(const std::string& id) const {
  const auto it = entries_.find(id);
  if (it == entries_.end() || !it->second.visible || it->second.pieces.empty()) return QColor();
  double c[4];
  lut_->GetTableValue(it->second.slot, c);
  return QColor::fromRgbF(c[0], c[1], c[2]);
}

}  // namespace sweepscan::ui
