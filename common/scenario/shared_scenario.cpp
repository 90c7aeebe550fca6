#include "common/scenario/shared_scenario.h"

#include <cmath>
#include <cstdio>
#include <map>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {
namespace {

void Append(std::string* text, const char* name, double v) {
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  *text += name;
  *text += '=';
  *text += buffer;
  *text += ';';
}

void Append(std::string* text, const char* name, const Eigen::Vector3d& v) {
  *text += name;
  *text += '[';
  Append(text, "x", v.x());
  Append(text, "y", v.y());
  Append(text, "z", v.z());
  *text += ']';
}

// world frame = the liver's frame, origin at its centre: a patient is under 2 m long, so a
// point 10 m from the origin is outside any scene (the robot base included)
constexpr double kMaxDistance_m = 10.0;

void CheckFinite(const Eigen::Vector3d& v, const std::string& key) {
  if (!v.allFinite()) throw InputError(Str("shared.", key, " must be finite"));
  CheckNormAtMost(v, kMaxDistance_m, "shared." + key, "m");
}

}  // namespace

void SharedScenario::Validate() const {
  if (markers_W.empty()) throw InputError("shared.markers: at least one marker is needed");
  if (markers_W.size() > 64)
    throw InputError(Str("shared.markers: at most 64 markers, got ", markers_W.size()));
  for (size_t i = 0; i < markers_W.size(); ++i) CheckFinite(markers_W[i], Str("markers[", i, "]"));
  CheckFinite(entry_W, "entry");
  CheckFinite(target_W, "target");
  if ((target_W - entry_W).norm() < 1e-6)
    throw InputError("shared.target must differ from shared.entry (the path has no direction)");
  if (!(approach_distance >= 0) || !std::isfinite(approach_distance))
    throw InputError(Str("shared.approach_distance must be >= 0 (m), got ", approach_distance));
  if (!(needle_length > 0) || !std::isfinite(needle_length))
    throw InputError(Str("shared.needle.length must be > 0 (m), got ", needle_length));
  if (!(needle_radius > 0) || !std::isfinite(needle_radius))
    throw InputError(Str("shared.needle.radius must be > 0 (m), got ", needle_radius));
  CheckFinite(tool_offset_F, "needle.tool_offset");
  CheckFinite(axis_F, "needle.axis");
  if (!(axis_F.norm() > 1e-9)) throw InputError("shared.needle.axis must be nonzero");
  if (!X_WB.matrix().allFinite()) throw InputError("shared.robot_base must be finite");
  CheckNormAtMost(X_WB.translation(), kMaxDistance_m, "shared.robot_base.position", "m");
  // the tip starts cm before the skin; biopsy needles are 5..30 cm long, 0.2..2 mm in radius
  CheckAtMost(approach_distance, 1.0, "shared.approach_distance", "m");
  CheckAtMost(needle_length, 2.0, "shared.needle.length", "m");
  CheckAtMost(needle_radius, 0.05, "shared.needle.radius", "m");
}

SharedScenario ReadSharedScenario(const YamlReader& root) {
  if (!root.Has("shared"))
    root.Fail("shared",
              "missing: the section both processes read (markers, entry, target, "
              "approach_distance, needle, robot_base)");
  const YamlReader node = root.Child("shared");
  node.CheckKeys({"markers", "entry", "target", "approach_distance", "needle", "robot_base"});
  SharedScenario s;
  for (const char* key : {"markers", "entry", "target"})
    if (!node.Has(key)) node.Fail(key, "missing");
  node.Read("markers", &s.markers_W);
  node.Read("entry", &s.entry_W);
  node.Read("target", &s.target_W);
  node.Read("approach_distance", &s.approach_distance);
  if (node.Has("needle")) {
    const YamlReader needle = node.Child("needle");
    needle.CheckKeys({"length", "radius", "tool_offset", "axis"});
    needle.Read("length", &s.needle_length);
    needle.Read("radius", &s.needle_radius);
    needle.Read("tool_offset", &s.tool_offset_F);
    needle.Read("axis", &s.axis_F);
  }
  node.Read("robot_base", &s.X_WB);
  ValidateAs([&] { s.Validate(); }, root.source(), "shared.", "shared.");
  return s;
}

std::string CanonicalText(const SharedScenario& s) {
  std::string text = "nsim-shared-1;";
  for (const Eigen::Vector3d& m : s.markers_W) Append(&text, "marker", m);
  Append(&text, "entry", s.entry_W);
  Append(&text, "target", s.target_W);
  Append(&text, "approach", s.approach_distance);
  Append(&text, "length", s.needle_length);
  Append(&text, "radius", s.needle_radius);
  Append(&text, "offset", s.tool_offset_F);
  Append(&text, "axis", s.axis_F);
  const Eigen::Matrix4d X = s.X_WB.matrix();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) Append(&text, "base", X(i, j));
  return text;
}

uint64_t ScenarioHash(const SharedScenario& shared) {
  uint64_t h = 14695981039346656037ull;  // FNV-1a 64 offset basis
  for (const unsigned char c : CanonicalText(shared)) {
    h ^= c;
    h *= 1099511628211ull;  // FNV prime
  }
  return h == 0 ? 1 : h;
}

void RejectKeysMovedToShared(const YamlReader& node, const std::string& section) {
  // (section.key, key in shared)
  static const std::multimap<std::string, std::pair<std::string, std::string>> moved = {
      {"patient", {"markers", "markers"}},
      {"patient", {"entry", "entry"}},
      {"patient", {"target", "target"}},
      {"needle", {"length", "needle.length"}},
      {"needle", {"radius", "needle.radius"}},
      {"needle", {"tool_offset", "needle.tool_offset"}},
      {"needle", {"axis", "needle.axis"}},
      {"insertion", {"approach_distance", "approach_distance"}},
      {"robot", {"base_pose", "robot_base"}},
      {"inverse", {"markers", "markers"}},
      {"inverse.needle", {"length", "needle.length"}},
      {"inverse.needle", {"radius", "needle.radius"}},
      {"inverse.needle", {"tool_offset", "needle.tool_offset"}},
      {"inverse.needle", {"axis", "needle.axis"}},
      {"controller.path", {"entry", "entry"}},
      {"controller.path", {"target", "target"}},
      {"controller.path", {"approach_distance", "approach_distance"}},
      {"controller", {"iiwa_base", "robot_base"}}};
  if (node.IsNull() || !node.IsMap()) return;
  const auto [begin, end] = moved.equal_range(section);
  for (auto it = begin; it != end; ++it)
    if (node.Has(it->second.first))
      node.Fail(it->second.first, "moved to shared." + it->second.second +
                                      " (written once for both processes)");
}

}  // namespace nsim
