#pragma once
// A transform that carries the names of its frames, for the boundaries where poses
// arrive from outside (messages, files): composing two of them checks that the frames
// chain, so that a T_map_odom is never applied to a pose in the map frame by mistake.

#include <Eigen/Geometry>
#include <string>

namespace liloc {

struct FramedTransform {
  std::string parent;  // frame the transform maps into
  std::string child;   // frame the transform maps from
  Eigen::Isometry3d T_parent_child = Eigen::Isometry3d::Identity();

  // (a->b) * (b->c) = (a->c); throws std::invalid_argument naming the frames if
  // this->child != rhs.parent.
  FramedTransform operator*(const FramedTransform& rhs) const;
  FramedTransform inverse() const;
};

}  // namespace liloc
