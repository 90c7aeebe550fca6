#include "common/scene/scene_config.h"

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

// runs a nested Validate() and renames its key prefix ("fem." -> "patient.liver.")
template <typename Fn>
void Renamed(Fn&& validate, const std::string& from, const std::string& to) {
  try {
    validate();
  } catch (const InputError& e) {
    std::string what = e.what();
    if (what.compare(0, from.size(), from) == 0) what = to + what.substr(from.size());
    throw InputError(what);
  }
}

void CheckFinite(const Eigen::Vector3d& v, const std::string& key) {
  if (!v.allFinite()) throw InputError(Str(key, " must be finite (m), got ", v.transpose()));
}

}  // namespace

void SkinConfig::Validate() const {
  Renamed([&] { fem.Validate(); }, "fem.", "patient.skin.");
  if (!X_WS.matrix().allFinite()) throw InputError("patient.skin.pose must be finite");
  if (!(attach_distance >= 0))
    throw InputError(Str("patient.skin.attach_distance must be >= 0 (m), got ", attach_distance));
}

void SceneNeedleConfig::Validate() const {
  if (kind == NeedleKind::kRigid) {
    rigid.Validate("needle");
  } else {
    flexible.Validate();
  }
  if (coupling.tissues.size() != 2)
    throw InputError(
        Str("needle coupling needs 2 tissues (skin, liver), got ", coupling.tissues.size()));
  coupling.tissues[0].Validate("needle.skin");
  coupling.tissues[1].Validate("needle.liver");
  coupling.bevel.Validate("needle.bevel");
}

void PatientSceneConfig::Validate() const {
  if (!(time_step > 0) || !std::isfinite(time_step))
    throw InputError(Str("patient.time_step must be > 0 (s), got ", time_step));
  if (!gravity.allFinite())
    throw InputError(Str("patient.gravity must be finite (m/s^2), got ", gravity.transpose()));
  Renamed([&] { liver.Validate(); }, "fem.", "patient.liver.");
  skin.Validate();
  if (ribs.empty()) throw InputError("patient.ribs must list at least one rib box");
  for (size_t i = 0; i < ribs.size(); ++i) ribs[i].Validate(Str("patient.ribs[", i, "]"));
  if (!(rib_contact_margin >= 0))
    throw InputError(Str("patient.rib_contact_margin must be >= 0 (m), got ", rib_contact_margin));
  diaphragm.Validate("patient.diaphragm");
  for (size_t i = 0; i < anchors.size(); ++i) anchors[i].Validate(Str("patient.anchors[", i, "]"));
  breathing.Validate();
  if (markers_W.empty()) throw InputError("patient.markers must list at least one marker");
  if (markers_W.size() > 64)
    throw InputError(Str("patient.markers: at most 64 markers, got ", markers_W.size()));
  for (size_t i = 0; i < markers_W.size(); ++i)
    CheckFinite(markers_W[i], Str("patient.markers[", i, "]"));
  CheckFinite(target_W, "patient.target");
  CheckFinite(entry_W, "patient.entry");
  if (!((target_W - entry_W).norm() > 1e-3))
    throw InputError("patient.entry and patient.target must be at least 1 mm apart");
  needle.Validate();
}

}  // namespace nsim
