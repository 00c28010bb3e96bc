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
#include <set>
#include <utility>
#include <vector>

#include "core/geometry/ray_box.h"
#include "ui/view/cloud_view.h"
#include "ui/view/paced_mapper.h"

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
  view_->SetLayerPicker([this](const CloudView::PickRay& ray, double* best_t, PickHit* hit) {
    return Pick(ray, best_t, hit);
  });
}

ProjectLayer::~ProjectLayer() {
  view_->SetLayerPicker(nullptr);
  Clear();
}

void ProjectLayer::Remove(Entry* e) {
  for (auto& actor : e->pieces) view_->RemoveLayer(actor);
  e->pieces.clear();
}

void ProjectLayer::Clear() {
  for (auto& [id, e] : entries_) Remove(&e);
  entries_.clear();
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
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(xyz);
  auto offsets = vtkSmartPointer<vtkTypeInt32Array>::New();
  offsets->SetNumberOfValues(static_cast<vtkIdType>(m + 1));
  auto connectivity = vtkSmartPointer<vtkTypeInt32Array>::New();
  connectivity->SetNumberOfValues(static_cast<vtkIdType>(m));
  for (size_t k = 0; k <= m; ++k) offsets->SetValue(static_cast<vtkIdType>(k), static_cast<int32_t>(k));
  for (size_t k = 0; k < m; ++k) connectivity->SetValue(static_cast<vtkIdType>(k), static_cast<int32_t>(k));
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  verts->SetData(offsets, connectivity);
  auto slot = vtkSmartPointer<vtkUnsignedCharArray>::New();
  slot->SetName("session");
  slot->SetNumberOfValues(static_cast<vtkIdType>(m));
  std::fill_n(slot->GetPointer(0), m, static_cast<unsigned char>(e.slot));
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetVerts(verts);
  poly->GetPointData()->SetScalars(slot);
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
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(rest);
  actor->GetProperty()->SetRepresentationToPoints();
  actor->PickableOff();
  actor->SetVisibility(e->visible);
  if (e->matrix) actor->SetUserMatrix(e->matrix);
  view_->AddLayer(actor, motion);
  e->pieces.push_back(actor);
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
      e.visible = shown;
      for (auto& actor : e.pieces) actor->SetVisibility(shown);
      changed = true;
    }
    if (s.project_from_session) {
      auto m = Matrix(*s.project_from_session);
      if (!SameMatrix(m, e.matrix)) {
        e.matrix = m;
        e.pose = *s.project_from_session;
        for (auto& actor : e.pieces) actor->SetUserMatrix(m);
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
  if (changed) view_->RequestRender();
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
  bool found = false;
  for (const auto& [id, e] : entries_) {
    if (!e.visible || e.pieces.empty()) continue;
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
    const size_t uploaded = std::min(e.next, all.size());
    for (size_t b = 0; b * ProjectCloud::kPickBlock < uploaded && b < blocks.size(); ++b) {
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
          hit->layer = QString::fromStdString(id);
          hit->local = q;
          hit->world = e.pose * q;
          found = true;
        }
      }
    }
  }
  return found;
}

QColor ProjectLayer::drawn_color(const std::string& id) const {
  const auto it = entries_.find(id);
  if (it == entries_.end() || !it->second.visible || it->second.pieces.empty()) return QColor();
  double c[4];
  lut_->GetTableValue(it->second.slot, c);
  return QColor::fromRgbF(c[0], c[1], c[2]);
}

}  // namespace sweepscan::ui
