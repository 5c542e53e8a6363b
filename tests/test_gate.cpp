#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "gate/sensor_gate.hpp"

namespace liloc {
namespace {

LidarScan scan(double period_s) {
  LidarScan s;
  s.utime_us = 1'700'000'000'000'000;
  s.scan_period_s = static_cast<float>(period_s);
  return s;
}

// Each refusal names what was wrong; good messages pass.
TEST(SensorGate, RefusesImplausibleSweepsAndImuSamplesWithTheirReason) {
  const SensorLimits limits;
  EXPECT_FALSE(implausible_scan(scan(0.1), limits));
  EXPECT_FALSE(implausible_scan(scan(0.0), limits));  // a snapshot sensor
  const auto nan_period = implausible_scan(scan(std::nan("")), limits);
  ASSERT_TRUE(nan_period);
  EXPECT_NE(nan_period->find("not finite"), std::string::npos) << *nan_period;
  EXPECT_TRUE(implausible_scan(scan(-0.1), limits));
  EXPECT_TRUE(implausible_scan(scan(2.0), limits));
  LidarScan before_1970 = scan(0.1);
  before_1970.utime_us = -5;
  EXPECT_TRUE(implausible_scan(before_1970, limits));

  const ImuSample still{1'700'000'000'000'000, {0, 0, 9.81}, {0, 0, 0.1}};
  EXPECT_FALSE(implausible_imu(still, limits));
  ImuSample spike = still;
  spike.accel_mps2.x() = 1e6;
  const auto too_much = implausible_imu(spike, limits);
  ASSERT_TRUE(too_much);
  EXPECT_NE(too_much->find("acceleration"), std::string::npos) << *too_much;
  ImuSample spin = still;
  spin.gyro_rps.z() = 100.0;
  EXPECT_TRUE(implausible_imu(spin, limits));
  ImuSample nan = still;
  nan.gyro_rps.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(implausible_imu(nan, limits));
}

// One message far from its stream's time is dropped and the stream goes on; when enough
// messages in a row agree on a new time, that becomes the stream's (a restarted clock).
TEST(StreamClock, DropsAJumpButFollowsAConfirmedNewTime) {
  StreamClock clock(5.0, 3);
  const int64_t t = 1'700'000'000'000'000;
  EXPECT_EQ(clock.check(t), StreamClock::Verdict::kAccept);
  EXPECT_EQ(clock.check(t + 100'000), StreamClock::Verdict::kAccept);
  EXPECT_EQ(clock.check(t + 3'600'000'000), StreamClock::Verdict::kJump);  // an hour ahead
  EXPECT_EQ(clock.check(t + 200'000), StreamClock::Verdict::kAccept);      // back on track
  EXPECT_EQ(clock.check(t - 1'000), StreamClock::Verdict::kAccept);  // a little late: not a jump
  EXPECT_EQ(clock.check(std::numeric_limits<int64_t>::max()), StreamClock::Verdict::kJump);
  EXPECT_EQ(clock.check(std::numeric_limits<int64_t>::min()), StreamClock::Verdict::kJump);
  // The clock restarted an hour back: three messages agree, then it is the stream's time.
  const int64_t back = t - 3'600'000'000;
  EXPECT_EQ(clock.check(back), StreamClock::Verdict::kJump);
  EXPECT_EQ(clock.check(back + 10'000), StreamClock::Verdict::kJump);
  EXPECT_EQ(clock.check(back + 20'000), StreamClock::Verdict::kNewTimeline);
  EXPECT_EQ(clock.check(back + 30'000), StreamClock::Verdict::kAccept);
  EXPECT_EQ(clock.new_timelines(), 1);
  EXPECT_EQ(clock.jumps(), 5);
}

TEST(SensorGate, LimitsAreValidated) {
  SensorLimits limits;
  limits.accel_limit_mps2 = std::nan("");
  EXPECT_THROW(limits.validate(), std::invalid_argument);
  limits = SensorLimits{};
  limits.confirm_jump_messages = 0;
  EXPECT_THROW(limits.validate(), std::invalid_argument);
  EXPECT_NO_THROW(SensorLimits{}.validate());
}

}  // namespace
}  // namespace liloc
