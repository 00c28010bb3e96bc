#include "ui/view/paced_mapper.h"

#include <vtkObjectFactory.h>
#include <vtkPolyData.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>

namespace sweepscan::ui {

vtkStandardNewMacro(PacedMapper);

void PacedMapper::RenderPiece(vtkRenderer* ren, vtkActor* act) {
  Superclass::RenderPiece(ren, act);
  if (pacer_ == nullptr || pacer_->limit == 0) return;
  vtkPolyData* input = GetInput();
  if (input != nullptr) pacer_->queued += static_cast<size_t>(input->GetNumberOfPoints());
  if (pacer_->queued < pacer_->limit) return;
  ren->GetRenderWindow()->WaitForCompletion();  // glFinish
  pacer_->queued = 0;
  ++pacer_->waits;
}

}  // namespace sweepscan::ui
