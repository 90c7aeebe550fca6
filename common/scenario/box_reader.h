#pragma once
// Oriented boxes in a scenario file: {center: [x, y, z], half_size: [a, b, c], rpy: [r, p, y]}
// (m, rad; rpy optional, the box's rotation Rz(y) Ry(p) Rx(r)), alone or as a list. Read by
// both processes' loaders (patient.ribs / diaphragm / anchors, inverse.anchors).

#include <string>
#include <vector>

#include "common/core/yaml_reader.h"
#include "common/mesh/oriented_box.h"

namespace nsim {

/// The box at `node`; InputError naming the key for a missing or unknown key or a bad value.
OrientedBox ReadOrientedBox(const YamlReader& node);

/// The list of boxes at parent.key (empty when the key is absent); InputError when it is not a
/// list of boxes.
std::vector<OrientedBox> ReadOrientedBoxes(const YamlReader& parent, const std::string& key);

}  // namespace nsim
