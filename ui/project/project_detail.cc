#include "ui/project/project_detail.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "core/cloud/cube_budget.h"
#include "core/cloud/packed_chunk.h"
#include "core/geometry/box_planes.h"

namespace sweepscan::ui {
namespace {

// A plane n . x + d >= 0 (inside) as four numbers.
using Plane4 = std::array<double, 4>;

InView BoxInView(const Eigen::AlignedBox3f& box, const std::vector<Plane4>& planes) {
  if (box.isEmpty()) return InView::kOut;  // No finite point.
  const float b[6] = {box.min().x(), box.max().x(), box.min().y(),
                      box.max().y(), box.min().z(), box.max().z()};
  return BoxAgainstPlanes(b, planes.front().data(), planes.size());
}

}  // namespace

void CountCubes(ProjectCloud* cloud) {
  cloud->piece_cubes.assign(cloud->piece_bounds.size(), 0);
  cloud->cube_keys.clear();
  std::unordered_map<uint64_t, uint32_t> index;
  for (size_t p = 0; p < cloud->piece_bounds.size(); ++p) {
    const Eigen::AlignedBox3f& box = cloud->piece_bounds[p];
    // A piece without a finite point is never in view (BoxInView): any cube.
    const Eigen::Vector3f c =
        box.isEmpty() ? Eigen::Vector3f::Zero() : Eigen::Vector3f(box.center());
    const float v[3] = {c.x(), c.y(), c.z()};
    const auto [it, fresh] =
        index.try_emplace(PackedChunk::CellKey(v), static_cast<uint32_t>(cloud->cube_keys.size()));
    if (fresh) cloud->cube_keys.push_back(it->first);
    cloud->piece_cubes[p] = it->second;
  }
}

std::vector<std::vector<uint32_t>> PlanDetail(const std::vector<DetailSession>& sessions,
                                              const DetailCamera& camera, size_t budget) {
  // The pieces in view, and their points counted in their cubes: one
  // demand list of every session's cubes, (session, cube).
  std::vector<std::vector<uint32_t>> in_view(sessions.size());
  std::vector<CubeDemand> demand;
  std::vector<std::pair<size_t, uint32_t>> owner;
  for (size_t s = 0; s < sessions.size(); ++s) {
    const ProjectCloud& cloud = *sessions[s].cloud;
    const Eigen::Matrix3d r = sessions[s].project_from_session.rotation().toRotationMatrix();
    const Eigen::Vector3d t = sessions[s].project_from_session.translation();
    // The four side planes: the near and far ones follow the clipping range,
    // which VTK fits to the props at the next render (a camera just placed
    // still has the old one), and the sides meet at the eye, so nothing
    // behind it is inside them all.
    std::vector<Plane4> planes;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d n(camera.planes[4 * k], camera.planes[4 * k + 1],
                              camera.planes[4 * k + 2]);
      const Eigen::Vector3d ns = r.transpose() * n;
      planes.push_back({ns.x(), ns.y(), ns.z(), n.dot(t) + camera.planes[4 * k + 3]});
    }
    if (!std::isnan(camera.clip_z)) {
      const Eigen::Vector3d up = r.row(2).transpose();  // z_p = up . x_s + t_z
      planes.push_back({-up.x(), -up.y(), -up.z(), camera.clip_z - t.z()});
    }
    const size_t n = cloud.positions.size();
    std::vector<uint32_t> count(cloud.cube_keys.size(), 0);
    constexpr size_t kPiecesPerBlock = ProjectCloud::kPickBlock / ProjectCloud::kPickPiece;
    // A block wholly in view brings its pieces untested, one out of view none.
    for (size_t b = 0; b < cloud.block_bounds.size(); ++b) {
      const InView block = BoxInView(cloud.block_bounds[b], planes);
      if (block == InView::kOut) continue;
      const size_t p1 = std::min(cloud.piece_bounds.size(), (b + 1) * kPiecesPerBlock);
      for (size_t p = b * kPiecesPerBlock; p < p1; ++p) {
        if (block != InView::kWhole && BoxInView(cloud.piece_bounds[p], planes) == InView::kOut)
          continue;
        const size_t first = p * ProjectCloud::kPickPiece;
        count[cloud.piece_cubes[p]] +=
            static_cast<uint32_t>(std::min(n, first + ProjectCloud::kPickPiece) - first);
        in_view[s].push_back(static_cast<uint32_t>(p));
      }
    }
    const Eigen::Vector3d eye = r.transpose() * (camera.eye - t);
    for (size_t c = 0; c < count.size(); ++c) {
      if (count[c] == 0) continue;
      const std::array<float, 6> cube = PackedChunk::CellBox(cloud.cube_keys[c]);
      demand.push_back({SquaredDistanceToBox(eye.data(), cube.data()), count[c]});
      owner.emplace_back(s, static_cast<uint32_t>(c));
    }
  }
  const std::vector<uint8_t> shifts = CubeShifts(demand, budget);
  std::vector<std::vector<uint8_t>> cube_shift(sessions.size());
  for (size_t s = 0; s < sessions.size(); ++s)
    cube_shift[s].assign(sessions[s].cloud->cube_keys.size(), 0);
  for (size_t j = 0; j < demand.size(); ++j)
    cube_shift[owner[j].first][owner[j].second] = shifts[j];

  // A piece's points at multiples of its cube's stride.
  std::vector<std::vector<uint32_t>> out(sessions.size());
  for (size_t s = 0; s < sessions.size(); ++s) {
    const ProjectCloud& cloud = *sessions[s].cloud;
    const size_t n = cloud.positions.size();
    for (const uint32_t p : in_view[s]) {
      const size_t stride = size_t{1} << cube_shift[s][cloud.piece_cubes[p]];
      const size_t first = size_t{p} * ProjectCloud::kPickPiece;
      const size_t end = std::min(n, first + ProjectCloud::kPickPiece);
      for (size_t i = (first + stride - 1) / stride * stride; i < end; i += stride) {
        out[s].push_back(static_cast<uint32_t>(i));
      }
    }
  }
  return out;
}

}  // namespace sweepscan::ui
