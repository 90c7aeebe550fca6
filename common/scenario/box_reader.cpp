#include "common/scenario/box_reader.h"

#include <Eigen/Geometry>

namespace nsim {

OrientedBox ReadOrientedBox(const YamlReader& node) {
  node.CheckKeys({"center", "half_size", "rpy"});
  OrientedBox box;
  if (!node.Has("center")) node.Fail("center", "missing");
  if (!node.Has("half_size")) node.Fail("half_size", "missing");
  node.Read("center", &box.center);
  node.Read("half_size", &box.half_size);
  Eigen::Vector3d rpy = Eigen::Vector3d::Zero();
  node.Read("rpy", &rpy);
  box.R_WB = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
              Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
              Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                 .toRotationMatrix();
  return box;
}

std::vector<OrientedBox> ReadOrientedBoxes(const YamlReader& parent, const std::string& key) {
  std::vector<OrientedBox> boxes;
  if (!parent.Has(key)) return boxes;
  const YamlReader list = parent.Child(key);
  if (!list.IsSequence()) list.Fail("expected a list of boxes {center, half_size, rpy}");
  for (size_t i = 0; i < list.size(); ++i) boxes.push_back(ReadOrientedBox(list.Element(i)));
  return boxes;
}

}  // namespace nsim
