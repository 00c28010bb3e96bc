// The 3D view: the cloud in chunks, the robot and its trajectory, a floor
// grid, axes and a colour bar, in a QVTKOpenGLNativeWidget.
//
// Memory (docs/cloud-store.md): the points themselves live once, in the
// cloud store's packed chunks (14 bytes a point, shared with the processing
// thread, paged to disk above the memory budget); VTK holds only what is
// drawn. Points arrive in order and fill the growing chunk (drawn in full);
// the store seals it and the view swaps it for the packed chunk.
//
// Level of detail with point budgets (cloud_view_lod.cc):
// * motion: while the camera moves or points stream in, a spatially even
//   sample of the sealed chunks, one point a grid cell, the cells doubled
//   until it holds at most lod_budget() points (core/geometry/voxel_sample.h);
// * rest: once the camera and the data have been still for kSettleMs, the
//   points in the view frustum, counted in the 0.5 m cubes of the chunks'
//   census (PackedChunk::cell_keys()) summed over the cloud, get strides a
//   cube, evenly dense on screen: nearer cubes finer, up to rest_budget()
//   points (core/cloud/cube_budget.h), built in slices of at most
//   kRefineSliceMs on the GUI thread; when the points in view fit the budget
//   the view draws every one of them (the whole cloud, or a corner of a
//   100 M-point cloud zoomed into). A rest level larger than the LOD budget is
//   drawn in progressive passes (cloud_view_progressive.cc): the motion
//   level first, then about a LOD budget of rest points a pass, nearest
//   first, over the same image, so no frame at rest holds the GUI thread
//   longer than a frame in motion.
// Colours: one float scalar per drawn point (the colour mode's), mapped by
// the shared lookup table; never three colour arrays.
//
// Render requests are coalesced: RequestRender() marks the view dirty and
// the owner's timer calls RenderIfDirty() (ParaView's pqView::render()).
//
// Threading: GUI thread only, like every VTK object; a click's pick
// searches on the view's pick thread (cloud_pick.h) over what it was given.
#ifndef SWEEPSCAN_UI_VIEW_CLOUD_VIEW_H_
#define SWEEPSCAN_UI_VIEW_CLOUD_VIEW_H_

#include <QVTKOpenGLNativeWidget.h>
#include <vtkSmartPointer.h>

#include <Eigen/Core>
#include <QColor>
#include <QImage>
#include <QPoint>
#include <QRectF>
#include <QString>
#include <QStringList>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <unordered_map>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/cloud/packed_chunk.h"
#include "core/geometry/path_cover.h"
#include "core/geometry/voxel_sample.h"
#include "core/pose/odometry.h"
#include "ui/view/cloud_pick.h"
#include "ui/view/paced_mapper.h"
#include "ui/view/point_values.h"

class QMouseEvent;
class QThreadPool;
class QTimer;
class vtkActor;
class vtkActor2D;
class vtkTextActor;
class vtkAxesActor;
class vtkGenericOpenGLRenderWindow;
class vtkLookupTable;
class vtkOrientationMarkerWidget;
class vtkPlaneCollection;
class vtkPoints;
class vtkPolyDataMapper;
class vtkPolyData;
class vtkRenderer;
class vtkScalarBarActor;

namespace sweepscan::ui {

class CloudView : public QVTKOpenGLNativeWidget {
  Q_OBJECT
 public:
  // Height, time and range come with every point; pass, deviation and
  // intensity are given after the fact (SetPointValues) and are NaN (grey)
  // until then. Intensity: the lidar's return strength, for lidars that
  // report one (an imported bag's; the X4 reports none), in grey levels
  // over the values' range, as intensity is shown in CloudCompare and RViz.
  enum class ColorMode { kHeight = 0, kTime = 1, kRange = 2, kPass = 3, kDeviation = 4, kIntensity = 5 };
  static constexpr int kColorModes = 6;
  static constexpr size_t kChunkPoints = 65536;
  // At most this many rest points (or one chunk's) in one draw batch.
  static constexpr size_t kRestBatchPoints = 32768;
  static constexpr int kSettleMs = 400;
  static constexpr int kRefineSliceMs = 25;

  explicit CloudView(QWidget* parent = nullptr);
  ~CloudView() override;

 signals:
  // Shift + left click on the cloud or a layer (the picking layer);
  // `context` is what the pick context (SetPickContext) said at the click.
  void pointPicked(const sweepscan::ui::PickHit& hit, int context);
  void colorModeChanged(int mode);  // A ColorMode.
  // has_point_values() changed: values given (SetPointValues) or cleared
  // with the cloud.
  void pointValuesChanged();
  // MoveCameraWithFrame moved the frame under the view: a level surface
  // under the focal point (the clip's height, else the focal point's)
  // moved by `dz` metres, and the clip with it. A height kept elsewhere in
  // the old frame (a ceiling found there) is that much higher now.
  void movedWithFrame(double dz);
  // The rest level was planned for the camera, now still or placed
  // (PlanRest): a project's layer plans its own for it (ProjectLayer).
  void restPlanned();

 public:
  // ---- Content ----
  void Clear();
  // Points in order; the view packs a growing chunk itself when it fills.
  // The view keeps the vector it is given (moved), and copies the other.
  void AppendPoints(std::vector<CloudPoint>&& points);
  void AppendPoints(const std::vector<CloudPoint>& points);
  // Chunks sealed by the cloud store, in order. The growing chunk's points
  // are the first points of the first one (the store seals what it grew).
  // `unpacked[i]`, if given and not null, is chunks[i]'s payload, unpacked
  // by the caller off the GUI thread (the chunk is compressed).
  void AppendSealed(const std::vector<std::shared_ptr<const PackedChunk>>& chunks,
                    const std::vector<std::shared_ptr<const ChunkPayload>>& unpacked = {});
  void SetRobotPose(const Pose2d& pose);
  void AppendTrajectory(const std::vector<Pose2d>& poses);
  size_t point_count() const { return point_count_; }
  size_t chunk_count() const { return chunks_.size(); }

  // ---- Appearance ----
  void SetColorMode(ColorMode mode);
  ColorMode color_mode() const { return color_mode_; }
  // The values the colour map spans now (the colour bar's ends).
  std::array<double, 2> color_range() const;
  // Values for kPass (0 = pass A, 1 = pass B of a circle drive, NaN none) or
  // kDeviation (mm from the fitted plane, NaN off every plane), one per point
  // in the order the points were appended; points beyond `values` (or
  // appended later) get NaN. Cleared with the cloud.
  void SetPointValues(ColorMode mode, const std::vector<float>& values) {
    SetPointValues(mode, Quantize(values));
  }
  // The same, quantised already (on a worker thread, for large clouds).
  void SetPointValues(ColorMode mode, const QuantizedValues& values);
  bool has_point_values(ColorMode mode) const {
    return has_values_[static_cast<int>(mode)];
  }
  // The colour bar's labels over [lo, hi]: round values (steps of 1, 2 or
  // 5 times a power of ten, three to seven of them) and the decimals they
  // need. Empty for an empty range.
  static std::vector<double> BarTicks(double lo, double hi, int* decimals);
  // The deviation colours span -max_mm (blue) .. 0 (white) .. +max_mm (red).
  void SetDeviationRange(double max_mm);
  // Draws only pass A (0), only pass B (1), or every point (-1). The picking
  // layer picks only what is drawn, so that an operator clicks a corner in
  // the pass on screen.
  void SetPassFilter(int pass);
  int pass_filter() const { return pass_filter_; }
  // Points drawn at full detail now (the pass filter applied).
  size_t drawn_point_count() const;
  void SetPointSize(double pixels);
  double point_size() const { return point_size_; }
  void SetGridVisible(bool visible);
  void SetAxesVisible(bool visible);
  void SetTrajectoryVisible(bool visible);
  void SetRobotVisible(bool visible);
  // View > Show Colour Bar. The bar is drawn only while the cloud has
  // points (a project's layers alone have no scalar to explain).
  void SetColorBarVisible(bool visible);
  bool color_bar_drawn() const;
  // The bar's category names, for the categories it shows (kPass).
  QStringList color_bar_categories() const;
  // The colour the colour mode gives a point's value (as drawn).
  QColor ColorOfValue(double value) const;
  // Hides every point above `z` (metres; NaN shows all): a room's ceiling,
  // so that the floor, the walls and a calibration target are seen from above.
  void SetClipHeight(double z);
  double clip_height() const { return clip_height_; }
  // The height of a room's ceiling (the highest dense horizontal layer of
  // points in the top third of the cloud's height), NaN if it has none.
  double FindCeiling() const;
  // Looks into the room: the ceiling (if any) clipped just under its height,
  // the camera 50 degrees above the floor from the south-west, the cloud
  // fitted. Returns the ceiling's height or NaN.
  double ShowRoom();
  // Points drawn at most while the camera moves or data streams.
  void SetLodBudget(size_t points);
  size_t lod_budget() const { return lod_budget_; }
  // Points drawn at most at rest (the finest detail the view reaches).
  void SetRestBudget(size_t points);
  size_t rest_budget() const { return rest_budget_; }
  // The driver finishes its queued work every `points` points drawn
  // (paced_mapper.h; 0: never). Unless set, chosen at the first frame:
  // kSoftwareDrawPace under a software renderer, 0 on a GPU.
  void SetDrawPace(size_t points) {
    pacer_.limit = points;
    draw_pace_set_ = true;
  }
  size_t draw_pace() const { return pacer_.limit; }
  size_t draw_waits() const { return pacer_.waits; }
  // Measured at 9.5 M points (docs/performance.md, "The driver's scenes"):
  // 262 144 holds ~65 MiB of the driver's scenes at most and costs no
  // frame rate; 65 536 cost a fifth of the rest level's.
  static constexpr size_t kSoftwareDrawPace = 262'144;
  // Whether the first frame found a software renderer (Mesa llvmpipe).
  bool software_renderer() const { return software_renderer_; }
  // While active: the motion level's cell, its longest side in mm (the
  // sealed chunks drawn one point a cell); -1 when the rest level is drawn.
  int lod_level() const {
    return lod_active_ ? static_cast<int>(std::lround(
                             1000.0 * std::max({motion_sample_.cell()[0], motion_sample_.cell()[1],
                                                motion_sample_.cell()[2]})))
                       : -1;
  }
  size_t motion_point_count() const { return motion_sample_.size(); }
  const std::array<double, 3>& motion_cell() const { return motion_sample_.cell(); }
  // The sealed chunks' motion level (the sample's points), whether drawn now or not.
  std::vector<Eigen::Vector3f> MotionPoints() const;
  // The motion level on (automatic while the camera moves; benchmarks force
  // it), or off: the rest level, planned and built at once (screenshots,
  // benchmarks; the settle timer builds it in slices instead).
  void SetLodActive(bool active);
  bool lod_active() const { return lod_active_; }
  // Points in VTK's arrays now (both levels), and the bytes they take.
  size_t vtk_point_count() const;
  // The positions of the points drawn now (the level shown of every chunk;
  // the pass filter and the clip are not applied), for tests and figures.
  // `scalars` (if given): each point's value in the colour mode, as drawn.
  std::vector<Eigen::Vector3f> DrawnPoints(std::vector<float>* scalars = nullptr) const;
  // The positions VTK is given to draw now: the shown batches' and the
  // growing chunk's vertex cells (the pass filter applied, the clip not; the
  // batches as the last frame built them), for tests.
  std::vector<Eigen::Vector3f> BatchedPoints() const;
  // Whether the rest level is being built (slices still to come).
  bool refining() const { return !refine_queue_.empty(); }

  // ---- Camera ----
  void ViewTop();
  void ViewOblique();
  void ViewFront();
  void ViewSide();
  // The cloud (and the robot) in the view, left of the colour bar when it
  // is shown (FitLeftOfColorBar); the grid is left out.
  void FitToCloud();
  // Turns the camera about the view's vertical axis (benchmarks, demos),
  // keeping the rest level as it is (a placement by the View menu or
  // LookAt plans it again for the new camera).
  void Orbit(double degrees);
  // Puts the camera at `position` looking at `focal`, z up.
  void LookAt(const Eigen::Vector3d& focal, const Eigen::Vector3d& position);
  // Moves the camera rigidly by `new_from_old` (its position, focal point
  // and view-up) as the points it looks at are re-expressed in another
  // frame (a project's change of anchor): what was on screen stays there,
  // the ceiling clip with it. Not a placement: camera_generation() is
  // unchanged.
  void MoveCameraWithFrame(const Rigid3d& new_from_old);
  // Counts the camera placements (View menu, LookAt, Orbit, the mouse);
  // FitToCloud keeps the direction and does not count.
  uint64_t camera_generation() const { return camera_generation_; }

  // ---- Picking layer ----
  // A Shift + click is picked on the view's pick thread (cloud_pick.h:
  // what the search needs is taken at the click, the cloud's points are
  // tested there, clicks answered in order) and pointPicked reports the
  // point; the GUI thread meanwhile keeps drawing and taking points in.
  // A pick is dropped if what it searched changed before it came back
  // (InvalidatePicks).
  static constexpr double kPickTolerancePx = 6.0;
  // Picks clicked and not yet reported (or dropped).
  int picks_in_flight() const { return picks_in_flight_; }
  // Waits for the pick thread to finish (their results are still to be
  // delivered by the event loop).
  void WaitForPicks();
  // Drops the picks in flight: what they search has changed (a layer's
  // owner removed, hid or moved a layer; Clear and SetLayerPicker do it).
  void InvalidatePicks() { ++pick_generation_; }
  // Asked at each Shift + click, on the GUI thread; its answer comes back
  // with the point (pointPicked). The point arrives 1-100 ms after the
  // click, and the owner's mode may have changed meanwhile (the distance
  // tool switched, pair picking ended): this is how the owner sends the
  // point where the click was made. Unset: 0.
  void SetPickContext(std::function<int()> context) { pick_context_ = std::move(context); }
  // The cloud point under display position `pos` (widget pixels), now, on
  // this thread: among the points within `tolerance_px` of the viewing ray,
  // the one nearest the camera. Chunks whose bounding box the widened ray
  // misses are skipped, so a click tests only the chunks under the cursor.
  // False if none.
  bool PickPoint(const QPoint& pos, Eigen::Vector3d* world, double tolerance_px = kPickTolerancePx);
  // The same, the layers' points included (through the layer picker).
  bool PickPoint(const QPoint& pos, PickHit* hit, double tolerance_px = kPickTolerancePx);
  using PickRay = ui::PickRay;
  using PickCounts = ui::PickCounts;
  // The layers' owner, called on the GUI thread at a click, returns its
  // search of the layers as they are then (LayerPick: a snapshot, run on
  // the pick thread). The view's own points and the layers' compete: the
  // nearest to the camera wins.
  using LayerPicker = std::function<LayerPick()>;
  void SetLayerPicker(LayerPicker picker);
  // What the last pick tested of the sealed chunks.
  const PickCounts& last_pick_counts() const { return last_pick_counts_; }
  // At most this many blocks are tested in entry order (by default as many
  // as the waves take, 224) before the rest are tested a chunk at a time; a
  // test sets 0 to send a small cloud's every block down the second path.
  void SetPickBlocksInOrder(size_t blocks) { pick_blocks_in_order_ = blocks; }
  // Where a world point lands in the widget (pixels), for tests and overlays.
  QPointF WorldToWidget(const Eigen::Vector3d& world);
  struct Marker {
    Marker() = default;
    Marker(const Eigen::Vector3d& p, const QColor& c, bool h = false, const QString& l = QString())
        : position(p), color(c), highlighted(h), label(l) {}
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    QColor color;
    bool highlighted = false;  // drawn larger
    QString label;             // drawn beside it in its colour ("" none): a pair's number
  };
  // Overlay markers (picked points) drawn on top of the cloud, their
  // labels over the view beside them.
  void SetMarkers(const std::vector<Marker>& markers);
  // The labels drawn at the last frame, in widget pixels (those of markers
  // off the view or behind the camera are not drawn).
  const std::vector<QRectF>& marker_label_boxes() const { return marker_label_boxes_; }

  // ---- Annotations (cloud_view_overlays.cc) ----
  // Fitted planes as translucent coloured rectangles with their names.
  // Each is edged in faint black (its extent seen through its points); a
  // selected one (the evaluation's table row) stands out: more opaque,
  // the others fainter, outlined in white, its name bold and placed first.
  struct PlanePatch {
    std::array<Eigen::Vector3d, 4> corners;
    QColor color;
    QString label;
    bool selected = false;
  };
  // Each plane's name is drawn over the view (2D, on top of the cloud) at
  // its rectangle's centre; a name that would cover one placed before it (a
  // floor's and a ceiling's centres meet seen from above, walls' seen end
  // on) is moved up or down, a line at a time, to the nearest clear place
  // within a few lines, or left out of that frame. Laid out every frame.
  void SetPlanes(const std::vector<PlanePatch>& planes);
  void SetPlanesVisible(bool visible);
  size_t plane_count() const { return plane_count_; }
  // The selected plane's index in SetPlanes' order (-1: none), and the
  // opacity each plane is drawn with (0..1).
  int selected_plane() const { return selected_plane_; }
  // The planes edged in black (all but the selected one, outlined in white).
  size_t plane_edges() const;
  double plane_opacity(size_t i) const;
  // The plane names drawn in the last frame: the plane's index in
  // SetPlanes' order and its box in widget pixels.
  struct PlaneLabelBox {
    int plane = 0;
    QRectF box;
  };
  const std::vector<PlaneLabelBox>& plane_label_boxes() const { return plane_label_boxes_; }
  // Where the distance's label drew in the last frame, in widget pixels
  // (empty when not drawn): over the cloud, at the segment's middle.
  QRectF measure_label_box() const { return measure_label_box_; }
  // Where the colour bar drew in the last frame, in widget pixels: its bar,
  // title and labels (empty when not drawn). Kept inside the view (a long
  // title on a narrow view moves the bar left) and kept clear of plane
  // labels, as is the axes' corner.
  const QRectF& color_bar_box() const { return color_bar_box_; }
  // How many times the colour bar's texts were measured (its title, a
  // category's name): a frame with nothing changed measures none.
  uint64_t color_bar_measures() const { return color_bar_measures_; }
  // The distance tool: a line between two points with its length.
  void SetMeasurement(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
  void ClearMeasurement();

  // ---- Layers (ui/project/: a project's session clouds) ----
  // Point actors drawn with the cloud and owned by someone else: the clip
  // (Hide Ceiling) and the point size apply to them, FitToCloud and
  // FindCeiling take their visible points in (through each actor's
  // matrix). Picked through the layer picker. Their owner keeps them within
  // the rest budget; `motion`, a mapper of a subset of the actor's points
  // (its owner's share of the LOD budget), is drawn in its place while the
  // motion level is, and the layers join the progressive passes at rest
  // like the rest batches (cloud_view_progressive.cc). Its mappers that are
  // PacedMapper are paced with the cloud's (SetDrawPace).
  void AddLayer(vtkActor* actor, vtkPolyDataMapper* motion = nullptr);
  // The visible layers' points a frame draws now (their motion mappers'
  // while the motion level is up).
  size_t layer_points_drawn() const;
  void RemoveLayer(vtkActor* actor);
  // The mappers layers draw at rest from now on, (actor, mapper) (their
  // owner's choice: the motion mapper while a rest level planned for the
  // camera is drawn beside it, ProjectLayer's detail). Their motion mappers
  // are kept. One pass over the layers, however many.
  void SetLayerRests(const std::vector<std::pair<vtkActor*, vtkPolyDataMapper*>>& rests);
  // The camera's six frustum planes (vtkCamera::GetFrustumPlanes: a x + b y
  // + c z + d >= 0 inside) for this view's aspect, and its eye.
  void ViewFrustum(double planes[24], double eye[3]) const;
  // What a rest level is planned for: the camera's position, focal point,
  // view-up, view angle and parallel scale, the viewport's size and the
  // clip height (-1e300 for none); and whether two differ by more than
  // rounding (an orbit's 30 steps of 12 degrees come back within 1e-13 m,
  // a placement moves the camera by millimetres at least).
  using CameraKey = std::array<double, 14>;
  CameraKey CurrentCameraKey() const;
  static bool SameCamera(const CameraKey& a, const CameraKey& b);

  // ---- Rendering ----
  void RequestRender() { dirty_ = true; }
  // The owner's timer: renders what changed, or the next progressive pass
  // at rest (one a call). True if it rendered.
  bool RenderIfDirty();
  // The whole frame now, all passes at once (screenshots, benchmarks).
  void RenderNow();
  bool drawing_passes() const { return progress_.active; }  // Progressive passes still to draw.
  size_t last_pass_points() const { return progress_.last_points; }  // Rest points of the last pass.
  uint64_t passes_drawn() const { return progress_.drawn; }  // Every pass so far, pass 0 included.
  uint64_t frames_rendered() const { return frames_rendered_; }
  double last_render_ms() const { return last_render_ms_; }
  // The rendered image (the framebuffer, as the operator sees it).
  QImage GrabImage();
  bool SaveScreenshot(const QString& path, QString* error);

 protected:
  void mousePressEvent(QMouseEvent* event) override;
  // A new size is drawn at the motion level, and at rest again once the
  // size has been still kSettleMs (cloud_view_progressive.cc).
  void resizeEvent(QResizeEvent* event) override;

 private:
  struct Chunk;
  struct Drawn;
  struct Batch;
  static constexpr size_t kBatchChunks = 16;
  // The motion level, a few hundred points a chunk, is drawn in batches of
  // kMotionBatches * kBatchChunks chunks.
  static constexpr size_t kMotionBatches = 8;
  void SyncBatches();  // Before every frame (cloud_view_batches.cc).
  // Bumped by whatever changes a chunk's drawn levels (or the chunks): the
  // batches are checked again only when it moved (SyncBatches).
  void DrawnChanged() { ++drawn_generation_; }
  // True if it added batches.
  bool SyncLevel(const std::vector<std::pair<size_t, size_t>>& ranges, bool rest,
                 std::vector<std::unique_ptr<Batch>>* batches);
  static const Drawn& RestSource(const Chunk& chunk);  // Its rest level, else its motion level.
  void ClearBatches();
  void InstallBatchObserver();
  Chunk* GrowingChunk();
  // Drops the growing chunk (the last of chunks_), keeping its level's
  // arrays, mapper and actor, hidden, for the next one (spare_growing_).
  void RetireGrowing();
  // Appends the batch's points first .. first + n - 1 (at most the growing
  // chunk's room; kept, not copied) to it, widening the running colour
  // ranges (AppendPoints).
  void AppendToGrowing(Chunk* chunk, const std::shared_ptr<const std::vector<CloudPoint>>& batch,
                       size_t first, size_t n, float* z_lo, float* z_hi, float* t_hi, float* r_hi);
  void SealGrowing();  // The view's own packing of a full growing chunk.
  // `payload`: the chunk's, if the caller has it unpacked (else pinned here).
  void AddSealed(std::shared_ptr<const PackedChunk> packed,
                 std::shared_ptr<const ChunkPayload> payload = nullptr);
  void RemoveChunkActors(Chunk* chunk);
  void NewDrawnActor(Drawn* drawn);
  // (Re)builds `drawn` as the rest level: every stride-th point of the
  // chunk, or if `shifts` is given (a byte a census cube) every
  // (1 << shift)-th of each cube's, none of a cube at kNoCube, stride the
  // finest; and its motion level's points.
  void BuildDrawn(Chunk* chunk, int stride, Drawn* drawn,
                  std::shared_ptr<const ChunkPayload> payload = nullptr,
                  std::vector<uint8_t> shifts = {});
  // Reads the points `index` (ascending) of the chunk into *drawn (from
  // `payload` if given, else the chunk pinned).
  void FillDrawn(Chunk* chunk, std::vector<uint32_t> index, int stride, Drawn* drawn,
                 std::shared_ptr<const ChunkPayload> payload = nullptr);
  // The motion level (cloud_view_lod.cc): a new sealed chunk's candidates
  // offered to the sample, the representatives it took drawn; after the
  // sample merged cells, each chunk's level keeps those still held.
  void BuildMotion(Chunk* chunk, std::shared_ptr<const ChunkPayload> payload = nullptr);
  void FilterMotion(Chunk* chunk);
  void FitMotion();
  void RebuildMotion();  // Every sealed chunk offered again (a larger budget).
  void Recolor(Chunk* chunk, Drawn* drawn);   // The colour mode's scalar.
  void RefilterVerts(const Chunk& chunk, Drawn* drawn);
  float ValueOf(const Chunk& chunk, int mode, size_t i) const;
  bool Passes(const Chunk& chunk, size_t i) const;
  void ApplyLodBudget();  // lod_budget_ to the sample: merged, or rebuilt if larger.
  void ShowLevels();  // The batches' visibility from lod_active_.
  void PlanRest();
  void MergeCensus();            // New sealed chunks' census cubes into the cloud's.
  bool RefineSlice(int max_ms);  // True when the queue is empty.
  // Progressive rest passes (cloud_view_progressive.cc).
  // A project's session piece (AddLayer): its actor, its own (rest) mapper
  // and its motion mapper (null: none, drawn whole at both levels).
  struct Layer {
    vtkSmartPointer<vtkActor> actor;
    vtkSmartPointer<vtkPolyDataMapper> rest, motion;
  };
  struct Progress {
    bool active = false;
    // The rest batches' and layers' actors to draw, nearest first, with
    // their points.
    std::vector<std::pair<vtkActor*, size_t>> order;
    size_t next = 0;            // The next pass's first batch in `order`.
    size_t last_points = 0;
    uint64_t drawn = 0;
  };
  bool WantPasses();  // Syncs the batches first.
  void StartPasses();  // Pass 0: the scene with the motion level for the rest level.
  void NextPass();
  void UpdateRanges(float z, float t, float r);
  void ApplyLookupTable();
  // The bar's labels at BarTicks(lo, hi).
  void SetBarTicks(double lo, double hi);
  // The colour bar explains the cloud's colours: not with no cloud (a
  // project's layers alone, coloured by session), nor when the mode has no
  // values (every point grey: a pass mode with no passes split).
  bool ColorBarShown() const {
    return color_bar_wanted_ && point_count_ > 0 && has_values_[static_cast<int>(color_mode_)];
  }
  void BuildGrid();
  void BuildColorBar();
  void BuildRobotAndTrajectory();
  void BuildMarkers();
  void BuildAxes();
  void BuildAnnotations();
  void ApplyPassFilter();
  void InstallObservers();  // LOD on camera motion, frame counting.
  void SetCamera(const double direction[3], const double up[3]);

  vtkSmartPointer<vtkGenericOpenGLRenderWindow> window_;
  vtkSmartPointer<vtkRenderer> renderer_;
  vtkSmartPointer<vtkLookupTable> lut_;
  DrawPacer pacer_;  // Shared by the cloud's mappers (NewDrawnActor).
  vtkSmartPointer<vtkScalarBarActor> color_bar_;
  vtkSmartPointer<vtkActor> grid_;
  vtkSmartPointer<vtkActor> robot_;
  vtkSmartPointer<vtkActor> trajectory_;
  vtkSmartPointer<vtkActor> markers_[2];  // normal, highlighted
  std::vector<Marker> shown_markers_;
  // The markers' labels, over the view beside their markers (placed each
  // frame by LayoutOverlayLabels): a label in the scene was cut by the walls
  // in front of it.
  struct MarkerLabel {
    vtkSmartPointer<vtkTextActor> actor;
    Eigen::Vector3d at;
  };
  std::vector<MarkerLabel> marker_labels_;
  std::vector<QRectF> marker_label_boxes_;
  LayerPicker layer_picker_;
  PickCounts last_pick_counts_;
  // The search of a pick at `pos` (GUI thread: the ray, the growing chunk
  // tested, the sealed chunks and the layers taken as they are).
  PickSearch PreparePick(const QPoint& pos, double tolerance_px);
  void StartPick(const QPoint& pos);  // A click's pick, on the pick thread.
  // Its result, back here.
  void FinishPick(uint64_t generation, int context, const PickResult& result);
  std::function<int()> pick_context_;
  std::unique_ptr<QThreadPool> pick_pool_;  // One thread, made at the first click.
  uint64_t pick_generation_ = 0;            // InvalidatePicks.
  int picks_in_flight_ = 0;
  size_t pick_blocks_in_order_ = std::numeric_limits<size_t>::max();
  vtkSmartPointer<vtkActor> planes_;
  vtkSmartPointer<vtkActor> plane_outline_;  // The selected plane's rectangle.
  vtkSmartPointer<vtkActor> plane_edges_;    // The others' rectangles.
  std::vector<vtkSmartPointer<vtkTextActor>> plane_labels_;
  std::vector<Eigen::Vector3d> plane_label_anchors_;  // the rectangles' centres
  std::vector<PlaneLabelBox> plane_label_boxes_;
  // Before each frame (the renderer's StartEvent): the colour bar, the
  // distance's label, the picks' numbers, then the planes' names clear of
  // them.
  void LayoutOverlayLabels();
  QRectF LayoutColorBar();   // before each frame; its box in display pixels
  // FitToCloud's last step: the fitted bounds moved out from under the bar.
  void FitLeftOfColorBar(const double bounds[6]);
  QRectF color_bar_box_;
  vtkSmartPointer<vtkTextActor> text_measure_;  // sizes the bar's texts, never drawn
  // LayoutColorBar's last result and what it was measured for (the view's
  // size and DPI, the lookup table, and the bar's, the table's and the two
  // text properties' modification times: the title, position and
  // visibility are the bar's own); the same again measures nothing.
  std::array<uint64_t, 8> color_bar_key_{};
  QRectF color_bar_layout_;
  uint64_t color_bar_measures_ = 0;
  size_t plane_count_ = 0;
  int selected_plane_ = -1;
  bool planes_visible_ = true;
  vtkSmartPointer<vtkActor> measure_line_;
  vtkSmartPointer<vtkTextActor> measure_label_;  // over the view, at measure_mid_
  Eigen::Vector3d measure_mid_ = Eigen::Vector3d::Zero();
  QRectF measure_label_box_;
  bool measuring_ = false;
  static constexpr double kMeasureColor[3] = {1.0, 0.35, 1.0};
  // `p` in display pixels (y up) into `d`; false if behind a perspective
  // camera (`d` then as VTK projects it, mirrored through the centre).
  bool ToDisplay(const Eigen::Vector3d& p, double* d) const;
  // A text drawn over the view (2D, on top of the cloud), centred on its
  // display position.
  static vtkSmartPointer<vtkTextActor> NewOverlayLabel();
  vtkSmartPointer<vtkPoints> trajectory_points_;
  vtkSmartPointer<vtkPolyData> trajectory_poly_;
  // The path as drawn: simplified to within 5 mm of every pose, ground
  // driven again drawn once on a 2 cm grid, so within 3.8 cm of every pose
  // (core/geometry/path_cover.h), about the 3-pixel line's own width when
  // a room fills the view.
  DrawnPath trajectory_path_{0.005, 0.02};
  vtkSmartPointer<vtkAxesActor> axes_;
  vtkSmartPointer<vtkOrientationMarkerWidget> axes_widget_;
  std::vector<std::unique_ptr<Chunk>> chunks_;
  std::unique_ptr<Chunk> spare_growing_;  // RetireGrowing: for GrowingChunk to reuse.
  // The cloud's census: every chunk's 0.5 m cubes (PackedChunk::CellKey)
  // summed, the rest plan's unit.
  std::unordered_map<uint64_t, uint32_t> cube_index_;  // key -> index below
  std::vector<uint64_t> cube_keys_;
  std::vector<uint32_t> cube_counts_;
  std::vector<std::unique_ptr<Batch>> motion_batches_, rest_batches_;
  std::vector<Layer> layers_;

  ColorMode color_mode_ = ColorMode::kHeight;
  double point_size_ = 2.0;
  double clip_height_ = std::numeric_limits<double>::quiet_NaN();
  vtkSmartPointer<vtkPlaneCollection> clip_planes_;
  void ApplyClip(vtkPolyDataMapper* mapper) const;
  size_t point_count_ = 0;
  bool color_bar_wanted_ = true;  // View > Show Colour Bar; drawn only with a cloud
  int64_t time_origin_ns_ = 0;
  bool have_origin_ = false;
  // Values given after the fact, quantised: v = lo + q * step.
  double value_lo_[3] = {0.0, 0.0, 0.0};
  double value_step_[3] = {1.0, 1.0, 1.0};
  // Data extents and the colour ranges shown (which grow by doubling).
  float z_min_ = 0.0f, z_max_ = 0.0f, t_max_ = 0.0f, r_max_ = 0.0f;
  double range_lo_[3] = {0.0, 0.0, 0.0};
  double range_hi_[3] = {3.0, 60.0, 8.0};
  bool has_values_[kColorModes] = {true, true, true, false, false, false};
  double intensity_lo_ = 0.0, intensity_hi_ = 1.0;
  double deviation_max_mm_ = 30.0;
  int pass_filter_ = -1;
  bool have_points_ = false;
  // Measured under llvmpipe on 2 cores (docs/performance.md, "Desktop
  // app"): a frame in motion costs ~25 ms plus ~0.4 us a point drawn (the
  // draw module's vertex work and the binning, the points' shading), so a
  // budget of 30 000 (15 000-30 000 drawn, the strides being powers of two)
  // keeps camera motion at about 30 frames/s, and a progressive pass of as
  // many rest points within about 30 ms; at rest 1 M points are a ~0.4 s
  // frame. Both defaults are set at the first frame from the renderer
  // (30 000 and 1 M in software, 1 M and 10 M on a GPU) unless
  // SetLodBudget() / SetRestBudget() chose them.
  size_t lod_budget_ = 30'000;
  size_t rest_budget_ = 1'000'000;
  bool lod_budget_set_ = false;
  bool rest_budget_set_ = false;
  bool draw_pace_set_ = false;
  bool renderer_known_ = false;
  bool software_renderer_ = false;
  VoxelSample motion_sample_{30'000};
  uint32_t next_serial_ = 0;
  size_t count_hint_ = 0;  // The cloud's size once a batch being added is in.
  bool lod_active_ = false;
  std::vector<Chunk*> refine_queue_;  // Nearest first.
  QTimer* refine_timer_ = nullptr;
  Progress progress_;
  bool interacting_ = false;
  // The camera and clip the rest level was last planned for (PlanRest).
  // A camera placed without the mouse (the View menu, LookAt, a project's
  // change of anchor) or a clip changed (Hide Ceiling) differs from it at
  // the next RenderIfDirty, which then goes to the motion level and back
  // to rest through the settle timer, as after a drag: the rest level kept
  // the old plan, dense where it looked before and thin where it looks
  // now, and without the cubes a clip had hidden.
  bool CameraMovedSincePlan() const;
  CameraKey planned_camera_{};
  uint64_t camera_generation_ = 0;
  uint64_t drawn_generation_ = 0;
  uint64_t synced_generation_ = ~uint64_t{0};  // drawn_generation_ at the last SyncBatches
  QTimer* settle_ = nullptr;
  bool dirty_ = true;
  uint64_t frames_rendered_ = 0;
  double last_render_ms_ = 0.0;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_VIEW_CLOUD_VIEW_H_
