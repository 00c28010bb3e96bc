#!/usr/bin/env bash
# The reference results of tests/core/evaluation/evaluation_truth_test.cc:
# the PCL version of the evaluation (StatisticalOutlierRemoval,
# SACSegmentation, KdTreeFLANN; core/evaluation/evaluation.cc at commit
# c266598, before the rewrite of issue 17) run on the test's simulated worlds.
#
#   SWEEPSCAN_DUMP_EVALUATION_WORLDS=DIR build/tests/evaluation_truth_test \
#       --gtest_filter='*DumpWorlds*'
#   scripts/pcl-evaluation-reference.sh DIR
#
# prints the three Expected blocks to paste into the test. Needs the git
# history (a full clone) and libpcl-dev; builds in a temporary folder.
set -euo pipefail
worlds=${1:?usage: scripts/pcl-evaluation-reference.sh DIR (the dumped worlds)}
root=$(cd "$(dirname "$0")/.." && pwd)
ref=c266598
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for f in core/evaluation/evaluation.cc core/evaluation/evaluation.h core/common/status.h \
         core/geometry/plane.h core/geometry/plane.cc; do
  mkdir -p "$work/$(dirname "$f")"
  git -C "$root" show "$ref:$f" > "$work/$f"
done
cat > "$work/main.cc" <<'EOF'
// The PCL version's results on one dumped world (uint64 n, then n x float
// x, y, z), in evaluation_truth_test.cc's Expected format.
#include <cstdint>
#include <cstdio>
#include <vector>

#include "core/evaluation/evaluation.h"

int main(int argc, char** argv) {
  if (argc != 3) return 2;
  std::FILE* f = std::fopen(argv[1], "rb");
  if (f == nullptr) return 1;
  uint64_t n = 0;
  if (std::fread(&n, 8, 1, f) != 1) return 1;
  std::vector<Eigen::Vector3f> pts(n);
  for (auto& p : pts) {
    float xyz[3];
    if (std::fread(xyz, 4, 3, f) != 3) return 1;
    p = Eigen::Vector3f(xyz[0], xyz[1], xyz[2]);
  }
  std::fclose(f);
  sweepscan::CloudEvaluation e;
  const sweepscan::Status s = sweepscan::EvaluateCloud(pts, sweepscan::EvaluationOptions(), &e);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  std::printf("const Expected %s = {%zu, %zu, %.9f,\n    {\n", argv[2], e.points_in,
              e.points_after_outliers, e.mean_nn_distance_m);
  for (const auto& p : e.planes) {
    std::printf("        {\"%s\", {%.9f, %.9f, %.9f}, %.9f, %zu, %.9f},\n", p.kind.c_str(),
                p.plane.normal.x(), p.plane.normal.y(), p.plane.normal.z(), p.plane.d,
                static_cast<size_t>(p.plane.count), p.plane.rms);
  }
  std::printf("    },\n    {\n");
  for (const auto& d : e.dimensions) {
    std::printf("        {%d, %d, \"%s\", %.9f},\n", d.plane_a, d.plane_b, d.axis.c_str(),
                d.distance_m);
  }
  std::printf("    }};\n");
  return 0;
}
EOF
g++ -O2 -std=c++17 -I"$work" -I/usr/include/pcl-1.13 -I/usr/include/eigen3 "$work/main.cc" \
    "$work/core/evaluation/evaluation.cc" "$work/core/geometry/plane.cc" -o "$work/reference" \
    -lpcl_common -lpcl_kdtree -lpcl_search -lpcl_filters -lpcl_sample_consensus \
    -lpcl_segmentation -llz4
echo "// lab5_truth"; "$work/reference" "$worlds/lab5_truth.bin" kLab5Truth
echo "// lab1_ekf"; "$work/reference" "$worlds/lab1_ekf.bin" kLab1Ekf
echo "// circle1_truth"; "$work/reference" "$worlds/circle1_truth.bin" kCircle1Truth
