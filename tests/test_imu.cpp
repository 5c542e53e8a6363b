#include <gtest/gtest.h>

#include <limits>

#include "imu/imu_buffer.hpp"

namespace liloc {
namespace {

ImuSample at(int64_t t) {
  ImuSample s;
  s.utime_us = t;
  s.accel_mps2 = Eigen::Vector3d(0, 0, 9.81);
  return s;
}

TEST(ImuBuffer, RefusesWhatWouldCorruptIntegration) {
  ImuBuffer buffer;
  EXPECT_EQ(buffer.add(at(100)), ImuBuffer::AddResult::kAccepted);
  EXPECT_EQ(buffer.add(at(100)), ImuBuffer::AddResult::kDuplicate);
  EXPECT_EQ(buffer.add(at(90)), ImuBuffer::AddResult::kOutOfOrder);
  ImuSample bad = at(110);
  bad.gyro_rps.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(buffer.add(bad), ImuBuffer::AddResult::kNonFinite);
  EXPECT_EQ(buffer.add(at(120)), ImuBuffer::AddResult::kAccepted);
  EXPECT_EQ(buffer.size(), 2u);
  EXPECT_EQ(buffer.counters().duplicate, 1);
  EXPECT_EQ(buffer.counters().out_of_order, 1);
  EXPECT_EQ(buffer.counters().non_finite, 1);
  EXPECT_EQ(buffer.counters().accepted, 2);
}

TEST(ImuBuffer, BetweenIncludesTheSampleBeforeTheStart) {
  ImuBuffer buffer;
  for (int64_t t = 0; t <= 100; t += 10) {
    buffer.add(at(t));
  }
  const auto s = buffer.between(25, 50);
  ASSERT_EQ(s.size(), 4u);  // 20, 30, 40, 50
  EXPECT_EQ(s.front().utime_us, 20);
  EXPECT_EQ(s.back().utime_us, 50);
  EXPECT_EQ(buffer.between(20, 30).front().utime_us, 20);
  EXPECT_EQ(buffer.between(-5, 5).front().utime_us, 0);
  buffer.drop_before(45);
  EXPECT_EQ(buffer.first_utime(), 40);
}

}  // namespace
}  // namespace liloc
