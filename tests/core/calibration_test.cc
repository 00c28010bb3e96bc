#include "core/calibration.h"

#include <gtest/gtest.h>

TEST(CalibrationPlaceholder, Builds) {}
