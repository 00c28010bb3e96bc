// Picks: resolving them against a recording, and the pairs file
// (docs/calibration.md, "Pairs file").
#include "core/calibration/picks.h"

#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "core/calibration/file_internal.h"
#include "core/calibration/internal.h"
#include "core/common/json_reader.h"

namespace sweepscan {

using calibration_internal::CheckHeader;
using calibration_internal::ParseJsonNoThrow;
using calibration_internal::ReadText;
using calibration_internal::RefName;

namespace {

// Sum of the two picks' distances to the samples they snap to, with pick a
// in windows[0] and b in windows[1]; infinity if either window is empty.
double SnapDistance(const Pick& a, const Pick& b, const SampleStore& store,
                    const std::vector<PassWindow>& windows, const RobotGeometry& geometry,
                    const MountingError& calibration) {
  double sum = 0.0;
  const Pick* p[2] = {&a, &b};
  for (int side = 0; side < 2; ++side) {
    LidarObservation o;
    if (!store.Nearest(windows[side], p[side]->world, geometry, calibration, &o).ok()) {
      return std::numeric_limits<double>::infinity();
    }
    sum += (ProjectObservation(o, geometry, calibration) - p[side]->world).norm();
  }
  return sum;
}

bool SwappedPassesFitBetter(const Pick& a, const Pick& b, const SampleStore& store,
                            const std::vector<PassWindow>& windows, const RobotGeometry& geometry,
                            const MountingError& calibration) {
  return SnapDistance(b, a, store, windows, geometry, calibration) <
         SnapDistance(a, b, store, windows, geometry, calibration);
}

}  // namespace

Status ResolvePairs(const std::vector<PickPair>& picks, const SampleStore& store,
                    const std::vector<PassWindow>& windows, const RobotGeometry& geometry,
                    const MountingError& calibration, std::vector<ObservationPair>* pairs) {
  if (windows.size() < 2) {
    return Status::Error("need two passes to resolve picks, found " +
                         std::to_string(windows.size()));
  }
  pairs->clear();
  for (size_t k = 0; k < picks.size(); ++k) {
    ObservationPair pair;
    const Pick* p[2] = {&picks[k].pass1, &picks[k].pass2};
    // World picks may name the passes either way round: an operator clicks
    // a corner in whichever sighting is on screen. The order that snaps both
    // picks nearer to their samples wins (the other order puts each pick on
    // the wrong ghost, centimetres away).
    if (!p[0]->has_sample && !p[1]->has_sample && SwappedPassesFitBetter(*p[0], *p[1], store,
                                                                         windows, geometry,
                                                                         calibration)) {
      std::swap(p[0], p[1]);
    }
    LidarObservation* o[2] = {&pair.pass1, &pair.pass2};
    for (int side = 0; side < 2; ++side) {
      const std::string where =
          "pair " + std::to_string(k + 1) + " pass" + std::to_string(side + 1) + ": ";
      Status s = p[side]->has_sample
                     ? store.Find(p[side]->sample, o[side])
                     : store.Nearest(windows[side], p[side]->world, geometry, calibration, o[side]);
      if (!s.ok()) return Status::Error(where + s.message());
      const int pass = PassOfTime(windows, o[side]->time_ns);
      if (pass != side) {
        return Status::Error(
            where + "sample " + RefName(o[side]->ref) + " is " +
            (pass < 0 ? std::string("in neither pass") : "in pass " + std::to_string(pass + 1)) +
            ", expected pass " + std::to_string(side + 1));
      }
    }
    pairs->push_back(pair);
  }
  return Status::Ok();
}

namespace {

Pick ParsePick(const JsonObject& o) {
  Pick p;
  o.AllowOnly({"scan", "beam", "world"});
  const bool has_sample = o.Has("scan") || o.Has("beam");
  if (has_sample == o.Has("world")) {
    o.Fail("", "give either scan and beam, or world, not " +
                   std::string(has_sample ? "both" : "neither"));
  }
  if (has_sample) {
    const int64_t scan = o.Integer("scan");
    const int64_t beam = o.Integer("beam");
    if (scan < 0 || scan > 0xffffffffLL) o.Fail("scan", "out of range: " + std::to_string(scan));
    if (beam < 0 || beam > 0xffff) o.Fail("beam", "out of range: " + std::to_string(beam));
    p.has_sample = true;
    p.sample = {static_cast<uint32_t>(scan), static_cast<uint16_t>(beam)};
  } else {
    const nlohmann::json& w = o.Array("world");
    if (w.size() != 3)
      o.Fail("world", "expected [x, y, z], got " + std::to_string(w.size()) + " values");
    for (int i = 0; i < 3; ++i) {
      if (!w[i].is_number())
        o.Fail("world", "element " + std::to_string(i) + " is " + JsonTypeName(w[i]));
      p.world[i] = w[i].get<double>();
      if (!std::isfinite(p.world[i]))
        o.Fail("world", "element " + std::to_string(i) + " is not finite");
    }
  }
  return p;
}

}  // namespace

Status ParsePairs(const std::string& text, const std::string& source,
                  std::vector<PickPair>* pairs) {
  nlohmann::json j;
  Status s = ParseJsonNoThrow(text, source, &j);
  if (!s.ok()) return s;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"format", "version", "pairs", "comment"});
    CheckHeader(root, "sweepscan-pairs");
    const nlohmann::json& list = root.Array("pairs");
    std::vector<PickPair> out;
    for (size_t k = 0; k < list.size(); ++k) {
      const JsonObject pair(list[k], "pairs[" + std::to_string(k) + "]");
      pair.AllowOnly({"pass1", "pass2", "label"});
      if (pair.Has("label")) pair.String("label");
      PickPair pp;
      pp.pass1 = ParsePick(pair.Object("pass1"));
      pp.pass2 = ParsePick(pair.Object("pass2"));
      out.push_back(pp);
    }
    *pairs = std::move(out);
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  return Status::Ok();
}

Status LoadPairsFile(const std::string& path, std::vector<PickPair>* pairs) {
  std::string text;
  Status s = ReadText(path, &text);
  if (!s.ok()) return s;
  return ParsePairs(text, path, pairs);
}

std::string PairsToJson(const std::vector<PickPair>& pairs) {
  nlohmann::json list = nlohmann::json::array();
  auto pick = [](const Pick& p) {
    nlohmann::json o;
    if (p.has_sample) {
      o["scan"] = p.sample.scan;
      o["beam"] = p.sample.beam;
    } else {
      o["world"] = {p.world.x(), p.world.y(), p.world.z()};
    }
    return o;
  };
  for (const auto& p : pairs) list.push_back({{"pass1", pick(p.pass1)}, {"pass2", pick(p.pass2)}});
  nlohmann::json root = {{"format", "sweepscan-pairs"}, {"version", 1}, {"pairs", list}};
  return root.dump(2) + "\n";
}

}  // namespace sweepscan
