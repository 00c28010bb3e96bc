// CloudView's draw batches: sealed chunks are drawn through one actor per
// batch of consecutive chunks, not one per chunk.
//
// Why: under Mesa llvmpipe a visible actor costs about 60 us a frame
// (mapper state, buffer binding, shader uniforms) whatever its size. A
// 100 M-point cloud is 1 519 chunks: one actor each made the motion level
// (97 000 points) run at 7.8 frames/s, of which ~90 ms a frame was actors.
// * The motion level (at most the LOD budget, ~40 points a chunk at 100 M)
//   is batched by kMotionBatches * kBatchChunks = 128 chunks: 12 actors.
// * The rest level is batched by at most kBatchChunks chunks and at most
//   kRestBatchPoints (32 768) drawn points, or one chunk: ~110 actors at
//   100 M. The bound on points lets the rest level be drawn in progressive
//   passes of about the LOD budget each (cloud_view_progressive.cc): a
//   batch of 16 chunks drawn whole would be a million points, a ~0.35 s
//   frame in software. Half a chunk rather than a whole one: the passes'
//   turns came to a median of 28 ms instead of 42 (the budget overshot
//   by less).
//
// A batch's arrays are the concatenation of its chunks' drawn arrays (the
// motion level, or for the rest level each chunk's rest level where it has
// one and its motion level where not), rebuilt before a frame when a member
// changed (VTK's modification times) or the members changed. The copies
// are at most the budgets (the LOD and the rest budget) in total.
#include <vtkAppendPolyData.h>
#include <vtkCallbackCommand.h>
#include <vtkProperty.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkTimeStamp.h>

#include <algorithm>
#include <memory>
#include <utility>
#include <vector>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {

void CloudView::SyncBatches() {
  // Nothing drawn changed since the last check: the batches hold. Asking
  // each chunk's poly data (vtkPolyData::GetMTime walks its points, cells
  // and arrays) cost ~3 ms a frame at 100 M points (3 000 levels, twice).
  if (drawn_generation_ == synced_generation_) return;
  synced_generation_ = drawn_generation_;
  size_t sealed = chunks_.size();
  if (sealed > 0 && !chunks_.back()->sealed()) --sealed;
  std::vector<std::pair<size_t, size_t>> motion, rest;  // [first, end) chunk ranges
  const size_t span = kMotionBatches * kBatchChunks;
  for (size_t first = 0; first < sealed; first += span) motion.emplace_back(first, std::min(sealed, first + span));
  size_t first = 0, points = 0;
  for (size_t j = 0; j < sealed; ++j) {
    const size_t n = RestSource(*chunks_[j]).size();
    if (j > first && (j - first == kBatchChunks || points + n > kRestBatchPoints)) {
      rest.emplace_back(first, j);
      first = j;
      points = 0;
    }
    points += n;
  }
  if (first < sealed) rest.emplace_back(first, sealed);
  const bool added_motion = SyncLevel(motion, false, &motion_batches_);
  const bool added_rest = SyncLevel(rest, true, &rest_batches_);
  if (added_motion || added_rest) ShowLevels();
}

const CloudView::Drawn& CloudView::RestSource(const Chunk& c) {
  return c.rest.stride > 0 ? c.rest : c.motion;
}

bool CloudView::SyncLevel(const std::vector<std::pair<size_t, size_t>>& ranges, bool rest,
                          std::vector<std::unique_ptr<Batch>>* batches) {
  while (batches->size() > ranges.size()) {
    renderer_->RemoveActor(batches->back()->drawn.actor);
    batches->pop_back();
  }
  const bool added = batches->size() < ranges.size();
  while (batches->size() < ranges.size()) {
    auto b = std::make_unique<Batch>();
    NewDrawnActor(&b->drawn);
    batches->push_back(std::move(b));
  }
  for (size_t i = 0; i < ranges.size(); ++i) {
    Batch& b = *(*batches)[i];
    std::vector<vtkPolyData*> sources;
    bool dirty = false;
    for (size_t j = ranges[i].first; j < ranges[i].second; ++j) {
      const Chunk& c = *chunks_[j];
      const Drawn& d = rest ? RestSource(c) : c.motion;
      if (!d.poly) continue;
      sources.push_back(d.poly);
      dirty = dirty || d.poly->GetMTime() > b.built;
    }
    if (!dirty && sources == b.sources) continue;
    b.sources = std::move(sources);
    auto append = vtkSmartPointer<vtkAppendPolyData>::New();
    for (vtkPolyData* s : b.sources) append->AddInputData(s);
    if (!b.sources.empty()) append->Update();
    b.drawn.poly = b.sources.empty() ? vtkSmartPointer<vtkPolyData>::New()
                                     : vtkSmartPointer<vtkPolyData>(append->GetOutput());
    b.drawn.mapper->SetInputData(b.drawn.poly);
    vtkTimeStamp now;
    now.Modified();
    b.built = now.GetMTime();
  }
  return added;
}

void CloudView::ClearBatches() {
  for (auto* level : {&motion_batches_, &rest_batches_}) {
    for (const auto& b : *level) renderer_->RemoveActor(b->drawn.actor);
    level->clear();
  }
}

void CloudView::InstallBatchObserver() {
  // Whoever renders (our timer, the interactor while the camera moves), the
  // batches are brought up to date first.
  auto sync = vtkSmartPointer<vtkCallbackCommand>::New();
  sync->SetClientData(this);
  sync->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    static_cast<CloudView*>(self)->SyncBatches();
  });
  window_->AddObserver(vtkCommand::StartEvent, sync, 1.0);  // Before the frame clock.
}

}  // namespace sweepscan::ui
