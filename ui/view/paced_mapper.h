// The cloud's mapper: VTK's OpenGL poly data mapper that, under a software
// rasterizer, lets the driver finish its queued work every so many points,
// so that the driver's memory for a frame stays bounded.
//
// Why (Mesa 22.3's llvmpipe, src/gallium/drivers/llvmpipe): the driver bins
// each point drawn into a "scene" (lp_setup_point.c: the rasterizer's
// triangle, a0/dadx/dady for each of its inputs and four edge planes, about
// 230-280 bytes a point with the colour as its one varying) that its
// rasterizer threads then draw. A scene holds at most 36 MiB
// (LP_SCENE_MAX_SIZE); when it is full, or flushed, setup takes the first
// scene whose rasterization has ended, and a new one (up to 64) when the
// threads still hold them all. A scene's memory is freed only when its slot
// is taken again (lp_setup_get_empty_scene). So a frame of 900 000 points,
// binned faster than two threads draw it, spread over six scenes, and their
// ~200 MiB stayed allocated after the frame, for as long as the app ran:
// a quarter of the app's resident memory at 10 M points (docs/performance.md,
// "The driver's scenes"). Waiting for the driver (glFinish) every `limit`
// points lets setup take the first slot again each time: at most about
// `limit` points' scenes stay held.
#ifndef SWEEPSCAN_UI_VIEW_PACED_MAPPER_H_
#define SWEEPSCAN_UI_VIEW_PACED_MAPPER_H_

#include <vtkOpenGLPolyDataMapper.h>

#include <cstddef>

namespace sweepscan::ui {

// Shared by the mappers of one view.
struct DrawPacer {
  size_t limit = 0;   // Points drawn between waits; 0: never wait (a GPU).
  size_t queued = 0;  // Points drawn since the last wait.
  size_t waits = 0;   // Waits so far (for tests and figures).
};

class PacedMapper : public vtkOpenGLPolyDataMapper {
 public:
  static PacedMapper* New();
  vtkTypeMacro(PacedMapper, vtkOpenGLPolyDataMapper);
  void SetPacer(DrawPacer* pacer) { pacer_ = pacer; }
  void RenderPiece(vtkRenderer* ren, vtkActor* act) override;

 protected:
  PacedMapper() = default;
  ~PacedMapper() override = default;

 private:
  PacedMapper(const PacedMapper&) = delete;
  void operator=(const PacedMapper&) = delete;
  DrawPacer* pacer_ = nullptr;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_VIEW_PACED_MAPPER_H_
