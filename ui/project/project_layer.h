// A project's sessions in the cloud view: one point actor a session, drawn
// as a layer of the CloudView (the clip and point size apply, FitToCloud
// fits them). Each actor holds its session's points in the session's own
// frame (the loaded positions, not copied: VTK reads them in place) under a
// user matrix project_from_session, so that placing, hiding or recolouring
// a session is a matrix, a visibility or a table entry, never a reload.
//
// Colour by session: every point carries one byte, its actor's slot,
// mapped through one shared 256-entry lookup table whose slot entries are
// the sessions' colours (the view's scalar path; no colour arrays).
// Unplaced sessions are not drawn. A session above its share of the rest
// budget (the view's, divided among the project's sessions) draws every
// k-th point. Each piece also has a motion level, every j-th of its drawn
// points within the session's share of the view's LOD budget, which the
// view draws while the camera moves and as the first of its progressive
// passes at rest (CloudView::AddLayer).
//
// Picking: the layer is the view's layer picker. A Shift + click tests,
// on the view's pick thread, the points of the drawn sessions (all of
// them, not only every k-th) through each session's pose, in the pieces
// its ray passes near (ProjectCloud::piece_bounds), nearest first, and
// reports the session's id and the point in the session's own frame, which
// is what a picked pair is made of.
//
// A session's points go to VTK in pieces of kPiecePoints, a few per GUI
// tick (Pump), as the view's chunks do: a frame that uploads a whole
// session (a few hundred thousand points) stalls the GUI for a quarter of a
// second under a software renderer. A piece holds its points in place
// (stride 1) or a thinned copy.
//
// GUI thread only, like every VTK object.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_LAYER_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_LAYER_H_

#include <vtkSmartPointer.h>

#include <QMetaObject>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/project/project.h"
#include "ui/project/project_jobs.h"
#include "ui/view/cloud_view.h"

class vtkActor;
class vtkFloatArray;
class vtkPolyData;
class vtkLookupTable;
class vtkMatrix4x4;
class vtkPolyDataMapper;

namespace sweepscan::ui {

class ProjectLayer {
 public:
  explicit ProjectLayer(CloudView* view);
  ~ProjectLayer();
  ProjectLayer(const ProjectLayer&) = delete;
  ProjectLayer& operator=(const ProjectLayer&) = delete;

  // Shows `project`: the sessions placed, visible and in `clouds` (by id),
  // at their pose, in their colour; drops actors of sessions gone or
  // rebuilt. Requests a render when anything changed.
  void Sync(const Project& project, const std::map<std::string, ProjectCloudPtr>& clouds);
  void Clear();
  // Hands the next pieces to the view (at most kPiecesPerPump); true while
  // pieces remain. The owner calls it from a timer while pending().
  bool Pump();
  bool pending() const;
  static constexpr size_t kPiecePoints = 65536;
  static constexpr int kPiecesPerPump = 2;

  // For tests and the status bar: sessions drawn now, their points drawn
  // (every k-th above the budget) and all their points (what is shown).
  std::vector<std::string> drawn_sessions() const;
  size_t drawn_points() const;
  size_t shown_points() const;
  // The colour the lookup table gives a drawn session's points (invalid if
  // it is not drawn).
  QColor drawn_color(const std::string& id) const;
  // The pose a drawn session is shown at (false if it is not drawn).
  bool drawn_pose(const std::string& id, Rigid3d* project_from_session) const;

  // The view's layer picker (CloudView::LayerPicker): the search of the
  // drawn sessions as they are now, for the pick thread, which finds the
  // nearest point of a drawn session under the ray, nearer than *best_t.
  LayerPick PickSnapshot() const;
  // That search, now.
  bool Pick(const CloudView::PickRay& ray, double* best_t, PickHit* hit) const;

  // The rest level planned for the view's camera (project_detail.h), for
  // the sessions thinned at rest (above their share of the rest budget):
  // their points nearest and largest on screen, up to the rest budget less
  // what is drawn anyway. While it is drawn the thinned sessions' pieces
  // draw their motion level at rest too. Planned whenever the view plans
  // its own (CloudView::restPlanned: the camera came to rest or was placed)
  // and when Sync changes what is shown. Its actors have an empty motion
  // level: the camera moving draws the pieces' motion level alone.
  // The plan runs on a thread of its own (70-120 ms for a 99.5 M-point
  // session), its result shown on the GUI thread unless the camera or the
  // sessions changed meanwhile (then the plan is made again).
  void PlanDetail();
  bool detail_pending() const;   // a plan runs or waits
  size_t detail_points() const;  // the planned points of the drawn sessions
  // The detail's points in the project's frame (tests, benchmarks).
  std::vector<Eigen::Vector3d> DetailPoints() const;
  // The drawn sessions' bounds in the project's frame, and how many of
  // their points lie within `r` of `c` there (benchmarks: what a view of
  // that spot could show).
  Eigen::AlignedBox3d drawn_bounds() const;
  size_t PointsNear(const Eigen::Vector3d& c, double r) const;

 private:
  struct Entry {
    ProjectCloudPtr cloud;
    std::vector<vtkSmartPointer<vtkActor>> pieces;  // built so far
    size_t stride = 1;
    // The motion level's: a multiple of stride (its points among the
    // drawn ones), every k-th point above the session's share of the view's
    // LOD budget.
    size_t motion_stride = 1;
    size_t next = 0;  // the first point of the next piece
    int slot = 0;
    bool visible = true;
    vtkSmartPointer<vtkMatrix4x4> matrix;
    Rigid3d pose;  // project_from_session, as the matrix
    size_t drawn = 0;  // points in the pieces built
    // Each piece's rest and motion mappers (motion null: the piece is drawn
    // whole at both levels).
    std::vector<vtkSmartPointer<vtkPolyDataMapper>> piece_rest, piece_motion;
    std::vector<vtkSmartPointer<vtkActor>> detail;                // PlanDetail's, if any
    std::vector<vtkSmartPointer<vtkPolyDataMapper>> detail_rest;  // their rest mappers
    bool detailed = false;  // in the plan shown: its pieces draw their motion level at rest
    size_t detail_points = 0;
  };
  Entry NewEntry(const ProjectCloudPtr& cloud, size_t sessions) const;
  void AddPiece(Entry* entry);
  // The points first, first + step, ... before last, as a vertex cloud of
  // slot bytes under the shared lookup table.
  vtkSmartPointer<vtkPolyDataMapper> PieceMapper(const Entry& e, size_t first, size_t last,
                                                 size_t step) const;
  // A point actor of the entry's (its visibility and pose) drawing `mapper`.
  vtkSmartPointer<vtkActor> EntryActor(const Entry& e, vtkPolyDataMapper* mapper) const;
  // A mapper of slot-byte vertices under the shared lookup table.
  vtkSmartPointer<vtkPolyDataMapper> SlotMapper(const vtkSmartPointer<vtkPolyData>& poly) const;
  void Remove(Entry* entry);
  // Removes the entry's detail actors; its pieces draw their rest level again.
  void DropDetail(Entry* entry);
  struct DetailResult;
  void FinishDetail(const DetailResult& result);  // GUI thread, the plan's thread ended
  void ApplyDetail(const DetailResult& result);
  int FreeSlot() const;

  CloudView* view_;
  vtkSmartPointer<vtkLookupTable> lut_;
  vtkSmartPointer<vtkPolyDataMapper> empty_;  // the detail's motion level: nothing
  QMetaObject::Connection planned_;           // CloudView::restPlanned -> PlanDetail
  std::unique_ptr<std::thread> detail_thread_;
  bool detail_wanted_ = false;       // planned again when the running plan ends
  struct DetailKey {
    std::vector<double> sessions;  // each planned session's cloud, pose and slot
    size_t budget = 0;
    CloudView::CameraKey camera{};
  };
  std::optional<DetailKey> planned_key_;  // what the last plan started was for
  std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
  std::map<std::string, Entry> entries_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_LAYER_H_
