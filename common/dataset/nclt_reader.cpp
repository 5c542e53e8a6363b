#include "dataset/nclt_reader.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "dataset/dataset_error.hpp"
#include "math/se3.hpp"

namespace liloc::dataset {
namespace {

constexpr size_t kPacketHeaderBytes = 24;  // magic 8, hit count 4, utime 8, padding 4
constexpr size_t kHitBytes = 8;            // x, y, z uint16, intensity, laser id uint8
constexpr uint16_t kPacketMagic = 44444;
// An HDL-32E packet holds at most 12 x 32 hits; a count far above that is corruption,
// refused before anything is allocated for it.
constexpr uint32_t kMaxHitsPerPacket = 65536;
constexpr int kHdl32Lasers = 32;
// Returns this close to the sensor axis (the robot itself) have no reliable azimuth.
constexpr float kMinAzimuthRange_m = 1.0f;

// liloc's frames are NCLT's turned by 180 deg about x (z down -> z up).
const Eigen::Isometry3d kF(Eigen::Matrix3d(Eigen::Vector3d(1, -1, -1).asDiagonal()));

// NCLT's pose convention (devkit ssc_to_homo): R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Isometry3d nclt_pose(double x, double y, double z, double roll_rad, double pitch_rad,
                            double yaw_rad) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX());
  return se3::make(q, Eigen::Vector3d(x, y, z));
}

Eigen::Isometry3d nclt_pose_deg(const std::array<double, 6>& x) {
  constexpr double kRadPerDeg = M_PI / 180.0;
  return nclt_pose(x[0], x[1], x[2], x[3] * kRadPerDeg, x[4] * kRadPerDeg, x[5] * kRadPerDeg);
}

uint16_t le16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t le32(const uint8_t* p) { return le16(p) | (static_cast<uint32_t>(le16(p + 2)) << 16); }
uint64_t le64(const uint8_t* p) { return le32(p) | (static_cast<uint64_t>(le32(p + 4)) << 32); }

float nclt_metres(uint16_t value) { return static_cast<float>(value * 0.005 - 100.0); }

uint8_t hdl32_ring(uint8_t laser_id) {
  return static_cast<uint8_t>(laser_id % 2 == 0 ? laser_id / 2 : 16 + laser_id / 2);
}

double wrap_two_pi(double angle) {
  angle = std::fmod(angle, 2 * M_PI);
  return angle < 0 ? angle + 2 * M_PI : angle;
}

std::string session_name(const std::string& session_dir) {
  std::filesystem::path p = std::filesystem::path(session_dir).lexically_normal();
  if (p.filename().empty()) {
    p = p.parent_path();  // "2012-01-08/" normalizes to a trailing empty name
  }
  return p.filename().string();
}

}  // namespace

void NcltConfig::validate() const {
  if (!(scan_period_s > 0.0)) {
    throw std::invalid_argument("scan_period_s must be > 0");
  }
  if (!std::isfinite(cut_azimuth_deg)) {
    throw std::invalid_argument("cut_azimuth_deg must be finite");
  }
  const auto finite = [](const std::array<double, 6>& x) {
    return std::all_of(x.begin(), x.end(), [](double v) { return std::isfinite(v); });
  };
  if (!finite(x_body_hits) || !finite(x_body_imu)) {
    throw std::invalid_argument("x_body_hits and x_body_imu must be finite");
  }
}

NcltReader::NcltReader(const std::string& session_dir, NcltConfig config)
    : hits_path_(session_dir + "/velodyne_hits.bin"), config_(std::move(config)) {
  config_.validate();
  hits_.open(hits_path_, std::ios::binary);
  if (!hits_) {
    throw DatasetError::in_file(hits_path_, "cannot open");
  }
  hits_size_bytes_ = std::filesystem::file_size(hits_path_);
  const std::string imu_path = session_dir + "/ms25.csv";
  if (std::filesystem::exists(imu_path)) {
    imu_ = std::make_unique<TextLineReader>(imu_path);
  }
  if (!config_.ground_truth_path.empty()) {
    ground_truth_path_ = config_.ground_truth_path;
  } else {
    const std::string file = "groundtruth_" + session_name(session_dir) + ".csv";
    for (const std::string& candidate : {session_dir + "/" + file, session_dir + "/../" + file}) {
      if (std::filesystem::exists(candidate)) {
        ground_truth_path_ = candidate;
        break;
      }
    }
  }
}

SensorSetup NcltReader::sensor_setup() const {
  SensorSetup setup;
  setup.sensor_model = "hdl32";
  setup.has_imu = imu_ != nullptr;
  setup.nominal_scan_period_s = static_cast<float>(config_.scan_period_s);
  setup.T_body_lidar =
      kF * nclt_pose_deg(config_.x_body_imu).inverse() * nclt_pose_deg(config_.x_body_hits) * kF;
  return setup;
}

Trajectory NcltReader::ground_truth() {
  if (ground_truth_path_.empty()) {
    return Trajectory();
  }
  TextLineReader reader(ground_truth_path_);
  const Eigen::Isometry3d T_body_imu = nclt_pose_deg(config_.x_body_imu);
  std::vector<StampedPose> poses;
  int64_t dropped = 0;
  for (std::string line; reader.next(line);) {
    const std::vector<double> v = reader.numbers(line, ',', 7);
    const bool finite = std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
    if (!finite || (!poses.empty() && v[0] * 1e-6 <= poses.back().time_s)) {
      ++dropped;
      continue;
    }
    const Eigen::Isometry3d T_world_body = nclt_pose(v[1], v[2], v[3], v[4], v[5], v[6]);
    poses.push_back({v[0] * 1e-6, kF * T_world_body * T_body_imu * kF});
  }
  mutable_stats().dropped_ground_truth_rows = dropped;
  return Trajectory(std::move(poses));  // strictly increasing times: cannot throw
}

std::optional<double> NcltReader::progress() const {
  if (hits_size_bytes_ == 0) {
    return 1.0;
  }
  return static_cast<double>(hits_offset_) / static_cast<double>(hits_size_bytes_);
}

bool NcltReader::read_imu(ImuSample& sample) {
  std::string line;
  if (imu_ == nullptr || !imu_->next(line)) {
    return false;
  }
  const std::vector<double> v = imu_->numbers(line, ',', 10);
  if (!std::isfinite(v[0])) {
    imu_->fail("non-finite utime");
  }
  sample.utime_us = static_cast<int64_t>(std::llround(v[0]));
  // Columns 1-3 are the magnetometer, which liloc does not use.
  sample.accel_mps2 = Eigen::Vector3d(v[4], -v[5], -v[6]);
  sample.gyro_rps = Eigen::Vector3d(v[7], -v[8], -v[9]);
  return true;
}

bool NcltReader::read_scan(LidarScan& scan) {
  while (closed_sweeps_.empty()) {
    if (!read_packet()) {
      if (sweep_.empty()) {
        return false;
      }
      close_sweep(sweep_.size());
    }
  }
  scan = std::move(closed_sweeps_.front());
  closed_sweeps_.pop_front();
  return true;
}

bool NcltReader::read_packet() {
  if (hits_ended_) {
    return false;
  }
  const uint64_t packet_offset = hits_offset_;
  uint8_t header[kPacketHeaderBytes];
  hits_.read(reinterpret_cast<char*>(header), kPacketHeaderBytes);
  const auto header_bytes = static_cast<size_t>(hits_.gcount());
  if (header_bytes == 0) {
    hits_ended_ = true;
    return false;
  }
  if (header_bytes < kPacketHeaderBytes) {
    throw DatasetError::at_byte(
        hits_path_, packet_offset,
        "truncated packet header (" + std::to_string(header_bytes) + " of 24 bytes)");
  }
  for (int i = 0; i < 4; ++i) {
    if (le16(header + 2 * i) != kPacketMagic) {
      throw DatasetError::at_byte(
          hits_path_, packet_offset,
          "bad packet magic " + std::to_string(le16(header)) + " " +
              std::to_string(le16(header + 2)) + " " + std::to_string(le16(header + 4)) + " " +
              std::to_string(le16(header + 6)) + " (expected 44444 four times)");
    }
  }
  const uint32_t hit_count = le32(header + 8);
  const auto utime_us = static_cast<int64_t>(le64(header + 12));
  if (hit_count > kMaxHitsPerPacket) {
    throw DatasetError::at_byte(hits_path_, packet_offset + 8,
                                "packet declares " + std::to_string(hit_count) +
                                    " hits, more than " + std::to_string(kMaxHitsPerPacket) +
                                    ": corrupt hit count");
  }
  const uint64_t body_offset = packet_offset + kPacketHeaderBytes;
  const uint64_t body_bytes = uint64_t{hit_count} * kHitBytes;
  if (body_offset + body_bytes > hits_size_bytes_) {
    throw DatasetError::at_byte(
        hits_path_, body_offset,
        "truncated packet: the header at byte " + std::to_string(packet_offset) + " declares " +
            std::to_string(hit_count) + " hits (" + std::to_string(body_bytes) + " bytes), only " +
            std::to_string(hits_size_bytes_ - body_offset) + " remain");
  }
  packet_buffer_.resize(body_bytes);
  hits_.read(reinterpret_cast<char*>(packet_buffer_.data()),
             static_cast<std::streamsize>(body_bytes));
  if (static_cast<uint64_t>(hits_.gcount()) != body_bytes) {
    throw DatasetError::at_byte(hits_path_, body_offset + static_cast<uint64_t>(hits_.gcount()),
                                "read failed");
  }
  hits_offset_ = body_offset + body_bytes;

  if (last_packet_utime_us_ && utime_us < *last_packet_utime_us_) {
    ++mutable_stats().dropped_lidar_packets_not_increasing;
    return true;
  }
  last_packet_utime_us_ = utime_us;
  for (uint32_t i = 0; i < hit_count; ++i) {
    const uint8_t* h = packet_buffer_.data() + size_t{i} * kHitBytes;
    const uint8_t laser_id = h[7];
    Hit hit;
    hit.utime_us = utime_us;
    // (x, -y, -z): the hits frame turned z-up, see the header.
    hit.point.position_m =
        Eigen::Vector3f(nclt_metres(le16(h)), -nclt_metres(le16(h + 2)), -nclt_metres(le16(h + 4)));
    hit.point.intensity = h[6];
    if (config_.laser_id_is_firing_order) {
      if (laser_id >= kHdl32Lasers) {
        throw DatasetError::at_byte(
            hits_path_, body_offset + size_t{i} * kHitBytes + 7,
            "laser id " + std::to_string(laser_id) + " is not an HDL-32E laser (0-31)");
      }
      hit.point.ring = hdl32_ring(laser_id);
    } else {
      hit.point.ring = laser_id;
    }
    add_hit(hit);
  }
  return true;
}

void NcltReader::add_hit(const Hit& hit) {
  const auto period_us = static_cast<int64_t>(std::llround(config_.scan_period_s * 1e6));
  // The 10 Hz fallback: no crossing for 1.5 periods, so cut at one period.
  while (!sweep_.empty() && hit.utime_us - sweep_.front().utime_us >= period_us * 3 / 2) {
    const int64_t cut_utime_us = sweep_.front().utime_us + period_us;
    const auto end = std::partition_point(sweep_.begin(), sweep_.end(),
                                          [&](const Hit& h) { return h.utime_us < cut_utime_us; });
    close_sweep(static_cast<size_t>(end - sweep_.begin()));
    ++mutable_stats().scans_cut_by_time;
  }
  const Eigen::Vector3f& p = hit.point.position_m;
  if (std::hypot(p.x(), p.y()) >= kMinAzimuthRange_m) {
    const double phase_rad =
        wrap_two_pi(std::atan2(p.y(), p.x()) - config_.cut_azimuth_deg * M_PI / 180.0);
    if (last_phase_rad_ && !sweep_.empty()) {
      const bool crossed = (*last_phase_rad_ > 1.5 * M_PI && phase_rad < 0.5 * M_PI) ||
                           (*last_phase_rad_ < 0.5 * M_PI && phase_rad > 1.5 * M_PI);
      if (crossed && hit.utime_us - sweep_.front().utime_us >= period_us / 2) {
        close_sweep(sweep_.size());
      }
    }
    last_phase_rad_ = phase_rad;
  }
  sweep_.push_back(hit);
}

void NcltReader::close_sweep(size_t end) {
  if (end == 0) {
    return;
  }
  LidarScan scan;
  scan.utime_us = sweep_.front().utime_us;
  const int64_t duration_us = sweep_[end - 1].utime_us - scan.utime_us;
  scan.scan_period_s = duration_us > 0 ? static_cast<float>(duration_us * 1e-6)
                                       : static_cast<float>(config_.scan_period_s);
  scan.points.reserve(end);
  for (size_t i = 0; i < end; ++i) {
    LidarPoint point = sweep_[i].point;
    point.time_offset_s = static_cast<float>((sweep_[i].utime_us - scan.utime_us) * 1e-6);
    scan.points.push_back(point);
  }
  closed_sweeps_.push_back(std::move(scan));
  sweep_.erase(sweep_.begin(), sweep_.begin() + static_cast<std::ptrdiff_t>(end));
}

}  // namespace liloc::dataset
