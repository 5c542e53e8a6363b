#include "math/framed_transform.hpp"

#include <stdexcept>

namespace liloc {

FramedTransform FramedTransform::operator*(const FramedTransform& rhs) const {
  if (child != rhs.parent) {
    throw std::invalid_argument("frame mismatch: cannot compose T_" + parent + "_" + child +
                                " with T_" + rhs.parent + "_" + rhs.child);
  }
  return {parent, rhs.child, T_parent_child * rhs.T_parent_child};
}

FramedTransform FramedTransform::inverse() const {
  return {child, parent, T_parent_child.inverse()};
}

}  // namespace liloc
