// The view's progressive passes drawn as the GUI's timer draws them
// (ui/view/cloud_view_progressive.cc), against the rest level drawn in one
// frame.
#ifndef SWEEPSCAN_TESTS_UI_PROGRESSIVE_PASSES_H_
#define SWEEPSCAN_TESTS_UI_PROGRESSIVE_PASSES_H_

#include <gtest/gtest.h>

#include <QImage>
#include <cstdio>

#include "tests/ui/image_compare.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::testing {

struct PassesDrawn {
  size_t passes = 0;  // after pass 0
  size_t points = 0;  // drawn by them
};

// From a render request: pass 0 (the scene in motion), then every pass,
// each drawing at most `max_pass_points`, until none is left. The image
// after the last pass is `whole` (the one-frame image) but for text's
// anti-aliased edges, and pass 0's is much further from it.
inline void DrawPassesToTheOneFrameImage(ui::CloudView* view, const QImage& whole,
                                         size_t max_pass_points, PassesDrawn* out) {
  view->RequestRender();
  ASSERT_TRUE(view->RenderIfDirty());
  ASSERT_TRUE(view->drawing_passes());
  const QImage first = view->grabFramebuffer();
  PassesDrawn d;
  while (view->drawing_passes() && d.passes < 1000) {
    ASSERT_TRUE(view->RenderIfDirty());
    ++d.passes;
    EXPECT_LE(view->last_pass_points(), max_pass_points);
    d.points += view->last_pass_points();
  }
  EXPECT_FALSE(view->RenderIfDirty());  // Nothing left to draw.
  const QImage last = view->grabFramebuffer();
  const size_t before = DifferingPixels(first, whole), after = DifferingPixels(last, whole);
  std::printf(
      "%zu points in %zu passes; pixels unlike the one-frame image: %zu after pass 0, "
      "%zu after the last\n",
      d.points, d.passes, before, after);
  EXPECT_LT(after, static_cast<size_t>(whole.width()) * whole.height() / 200);
  EXPECT_GT(before, 10 * after + 1000);
  *out = d;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_PROGRESSIVE_PASSES_H_
