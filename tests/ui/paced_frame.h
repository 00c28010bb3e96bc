// A frame drawn under the software renderer's pacing (ui/view/paced_mapper.h)
// against the same frame unpaced.
#ifndef SWEEPSCAN_TESTS_UI_PACED_FRAME_H_
#define SWEEPSCAN_TESTS_UI_PACED_FRAME_H_

#include <gtest/gtest.h>

#include <QImage>
#include <cstdio>

#include "tests/ui/image_compare.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::testing {

// Draws the view's frame of `points` points unpaced (no wait) and paced
// every `pace` points: a wait once a pace's worth of mappers (each at most
// `mapper_points`) is drawn, never sooner, and the unpaced image pixel for
// pixel. The pace is left as set.
inline void ExpectPacedFrameWaitsAndMatches(ui::CloudView* view, size_t points, size_t pace,
                                            size_t mapper_points) {
  view->SetDrawPace(0);
  size_t waits = view->draw_waits();
  const QImage unpaced = view->GrabImage();
  EXPECT_EQ(view->draw_waits(), waits);
  view->SetDrawPace(pace);
  waits = view->draw_waits();
  const QImage paced = view->GrabImage();
  const size_t frame_waits = view->draw_waits() - waits;
  std::printf("%zu points a frame, paced every %zu: %zu waits\n", points, pace, frame_waits);
  EXPECT_GE(frame_waits, points / (pace + mapper_points));
  EXPECT_LE(frame_waits, points / pace + 1);
  EXPECT_EQ(DifferingPixels(paced, unpaced), 0u);
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_PACED_FRAME_H_
