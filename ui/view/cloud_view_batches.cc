// CloudView's draw batches: sealed chunks are drawn through one actor per
// level for every kBatchChunks consecutive chunks, not one per chunk.
//
// Why: under Mesa llvmpipe a visible actor costs about 60 us a frame
// (mapper state, buffer binding, shader uniforms) whatever its size. A
// 100 M-point cloud is 1 519 chunks: one actor each made the motion level
// (97 000 points) run at 7.8 frames/s, of which ~90 ms a frame was actors.
// With batches of 16 chunks it is 95 actors a level. The motion level is
// thinner still (at most the LOD budget, ~40 points a chunk at 100 M), so
// its actors span 8 batches (128 chunks): 12 actors, 5 ms a frame less.
//
// A batch's arrays are the concatenation of its chunks' drawn arrays (the
// motion level, or for the rest level each chunk's rest level where it has
// one and its motion level where not), rebuilt before a frame when a member
// changed (VTK's modification times) or the members' levels changed. The
// copies are at most the budgets (the LOD and the rest budget) in total.
#include <vtkAppendPolyData.h>
#include <vtkCallbackCommand.h>
#include <vtkProperty.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkTimeStamp.h>

#include <algorithm>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {

void CloudView::SyncBatches() {
  size_t sealed = chunks_.size();
  if (sealed > 0 && !chunks_.back()->sealed()) --sealed;
  const size_t want = (sealed + kBatchChunks - 1) / kBatchChunks;
  while (batches_.size() > want) {
    for (Batch::Level& l : batches_.back()->level) renderer_->RemoveActor(l.drawn.actor);
    batches_.pop_back();
  }
  if (batches_.size() < want) {
    while (batches_.size() < want) {
      auto b = std::make_unique<Batch>();
      for (Batch::Level& l : b->level) NewDrawnActor(&l.drawn);
      batches_.push_back(std::move(b));
    }
    ShowLevels();
  }
  for (size_t i = 0; i < batches_.size(); ++i) {
    for (int k = 0; k < 2; ++k) {
      // Level 0 (motion) of every kMotionBatches-th batch spans that many
      // batches' chunks; of the others it stays empty.
      const size_t span = k == 0 ? (i % kMotionBatches == 0 ? kMotionBatches : 0) : 1;
      const size_t first = i * kBatchChunks, end = std::min(sealed, first + span * kBatchChunks);
      Batch::Level& l = batches_[i]->level[k];
      std::vector<vtkPolyData*> sources;
      bool dirty = false;
      for (size_t j = first; j < end; ++j) {
        const Chunk& c = *chunks_[j];
        const Drawn& d = k == 1 && c.rest.stride > 0 ? c.rest : c.motion;
        if (!d.poly) continue;
        sources.push_back(d.poly);
        dirty = dirty || d.poly->GetMTime() > l.built;
      }
      if (!dirty && sources == l.sources) continue;
      l.sources = std::move(sources);
      auto append = vtkSmartPointer<vtkAppendPolyData>::New();
      for (vtkPolyData* s : l.sources) append->AddInputData(s);
      if (!l.sources.empty()) append->Update();
      l.drawn.poly = l.sources.empty() ? vtkSmartPointer<vtkPolyData>::New()
                                       : vtkSmartPointer<vtkPolyData>(append->GetOutput());
      l.drawn.mapper->SetInputData(l.drawn.poly);
      vtkTimeStamp now;
      now.Modified();
      l.built = now.GetMTime();
    }
  }
}

void CloudView::ClearBatches() {
  for (auto& b : batches_) {
    for (Batch::Level& l : b->level) renderer_->RemoveActor(l.drawn.actor);
  }
  batches_.clear();
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
