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

Pick SamplePick(const LidarObservation& o) {
  Pick p;
  p.has_sample = true;
  p.sample.time_ns = o.time_ns;
  p.sample.range_m = o.range_m;
  p.sample.theta_rad = o.theta;
  return p;
}

Pick PositionPick(const SampleRef& ref) {
  Pick p;
  p.has_sample = true;
  p.by_position = true;
  p.position = ref;
  return p;
}

Status FindPickedSample(const Pick& pick, const SampleStore& store, LidarObservation* out) {
  if (!pick.has_sample) return Status::Error("a world pick names no sample");
  if (!pick.by_position) return store.Find(pick.sample, out);
  double gap_s = 0.0;
  if (store.LostSamplesBefore(pick.position, &gap_s)) {
    // The beam is the position as received: counted from the other end of
    // the gap, it may be another sample than when the file was written.
    return Status::Error(
        "sample " + RefName(pick.position) +
        " is named by its position in the revolution as received (an older pairs file), and "
        "that revolution lost samples before it (a gap of " +
        calibration_internal::Num(gap_s * 1e3) +
        " ms: a lost packet), so it may name another sample than when the file was written; "
        "pick it again (picks are now named by time, docs/calibration.md)");
  }
  return store.Find(pick.position, out);
}

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
          calibration_internal::PairName(k) + " pass" + std::to_string(side + 1) + ": ";
      Status s = p[side]->has_sample
                     ? FindPickedSample(*p[side], store, o[side])
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
  o.AllowOnly({"time_ns", "range_m", "theta_rad", "scan", "beam", "world"});
  const bool by_time = o.Has("time_ns");
  const bool by_position = o.Has("scan") || o.Has("beam");
  const int forms = int{by_time} + int{by_position} + int{o.Has("world")};
  if (forms != 1) {
    o.Fail("", "give one of time_ns, scan and beam, or world, not " +
                   std::string(forms == 0 ? "none" : "several"));
  }
  if (!by_time && (o.Has("range_m") || o.Has("theta_rad"))) {
    o.Fail(o.Has("range_m") ? "range_m" : "theta_rad", "only checks a pick by time_ns");
  }
  if (by_time) {
    p.has_sample = true;
    p.sample.time_ns = o.Integer("time_ns");
    if (o.Has("range_m")) p.sample.range_m = o.Number("range_m");
    if (o.Has("theta_rad")) p.sample.theta_rad = o.Number("theta_rad");
  } else if (by_position) {
    const int64_t scan = o.Integer("scan");
    const int64_t beam = o.Integer("beam");
    if (scan < 0 || scan > 0xffffffffLL) o.Fail("scan", "out of range: " + std::to_string(scan));
    if (beam < 0 || beam > 0xffff) o.Fail("beam", "out of range: " + std::to_string(beam));
    p = PositionPick({static_cast<uint32_t>(scan), static_cast<uint16_t>(beam)});
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
    // The format first: a calibration file given as pairs says what it is,
    // not "mounting_error_rad: unknown key".
    CheckHeader(root, "sweepscan-pairs");
    root.AllowOnly({"format", "version", "pairs", "comment"});
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
    if (p.has_sample && p.by_position) {
      o["scan"] = p.position.scan;
      o["beam"] = p.position.beam;
    } else if (p.has_sample) {
      o["time_ns"] = p.sample.time_ns;
      if (std::isfinite(p.sample.range_m)) o["range_m"] = p.sample.range_m;
      if (std::isfinite(p.sample.theta_rad)) o["theta_rad"] = p.sample.theta_rad;
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
