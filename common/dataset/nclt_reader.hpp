#pragma once
// NCLT (University of Michigan North Campus Long-Term; Segway with a Velodyne HDL-32E
// and a Microstrain 3DM-GX3-45 "MS25" IMU). One session folder, as the downloads unpack:
//   <session>/velodyne_hits.bin   packets: 4 x uint16 magic 44444, uint32 hit count,
//                                 uint64 utime, 4 bytes padding, then per hit uint16 x, y, z
//                                 (metres = value * 0.005 - 100), uint8 intensity,
//                                 uint8 laser id; little endian (NCLT devkit read_vel_hits.py)
//   <session>/ms25.csv            utime, mag x y z, accel x y z [m/s^2], rot r p h [rad/s]
//   groundtruth_<session>.csv     utime, x, y, z, roll, pitch, yaw (in the session folder
//                                 or its parent; rows of NaN where there is no solution)
//
// Frames. NCLT's body frame and its world frame are NED-like: x forward / north,
// y right / east, z down; a pose is R = Rz(yaw) Ry(pitch) Rx(roll) (devkit ssc_to_homo).
// The MS25 axes are the body axes (x_body_imu has no rotation). liloc works z-up, so every
// frame is turned by F = Rx(180 deg), which keeps x and negates y and z:
//   liloc body  = MS25 frame * F   (x forward, y left, z up; the IMU is the body)
//   liloc lidar = hits frame * F   (the frame the hits are stored in, z up)
//   liloc world = NCLT world * F   (x north, y west, z up)
// so samples and points become (x, -y, -z), the ground truth becomes
// T_world_body = F * T_ncltworld_ncltbody * T_ncltbody_imu * F, and
// T_body_lidar = F * T_ncltbody_imu^-1 * T_ncltbody_hits * F.
// The devkit treats the hits as body-frame points (project_vel_to_cam.py projects them
// with T_cam_body alone), hence x_body_hits = 0 by default; NCLT's published sensor pose
// x_body_vel = [0.002, -0.004, -0.957, 0.807, 0.166, -90.703] goes there instead if the
// hits are in the sensor frame.
//
// Sweeps. The file is a stream of packets (~0.5 ms each). A sweep ends where the hit
// azimuth crosses cut_azimuth_deg (behind the robot by default), in either spin
// direction, once the sweep spans half a nominal period (so that jitter at the cut
// cannot end a sweep twice); if no crossing is seen for 1.5 periods, the sweep is cut at
// one nominal period instead (the 10 Hz fallback, counted in DatasetStats). Each point's
// time is its packet's utime: the hits of one packet share it (packet resolution, about
// 2 degrees of rotation at 10 Hz).
//
// Rings. The laser id is the HDL-32E firing index, which interleaves elevations (id 0 is
// -30.67 deg, id 1 is -9.33 deg, ...); ring = id / 2 for even ids, 16 + id / 2 for odd
// ones puts them in elevation order (0 = lowest).

#include <array>
#include <deque>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dataset/sensor_dataset_reader.hpp"
#include "dataset/text_line_reader.hpp"

namespace liloc::dataset {

struct NcltConfig {
  double scan_period_s = 0.1;            // nominal: the HDL-32E spins at 10 Hz
  double cut_azimuth_deg = 180.0;        // in the lidar frame; 180 = behind the robot
  bool laser_id_is_firing_order = true;  // false: use the laser id as the ring
  // NCLT's own pose convention: x, y, z [m], roll, pitch, yaw [deg], in the body frame.
  std::array<double, 6> x_body_hits = {0, 0, 0, 0, 0, 0};
  std::array<double, 6> x_body_imu = {-0.11, -0.18, -0.71, 0, 0, 0};
  // Empty: groundtruth_<session>.csv in the session folder, else in its parent.
  std::string ground_truth_path;

  template <class V>
  void visit_fields(V& v) {
    v("scan_period_s", scan_period_s);
    v("cut_azimuth_deg", cut_azimuth_deg);
    v("laser_id_is_firing_order", laser_id_is_firing_order);
    v("x_body_hits", x_body_hits);
    v("x_body_imu", x_body_imu);
    v("ground_truth_path", ground_truth_path);
  }
  void validate() const;
};

class NcltReader : public SensorDatasetReader {
 public:
  // session_dir: the folder holding velodyne_hits.bin (required) and ms25.csv (optional:
  // without it the dataset has no IMU). Throws DatasetError if the hits file is missing.
  explicit NcltReader(const std::string& session_dir, NcltConfig config = {});

  SensorSetup sensor_setup() const override;
  Trajectory ground_truth() override;
  std::optional<double> progress() const override;

 protected:
  bool read_imu(ImuSample& sample) override;
  bool read_scan(LidarScan& scan) override;

 private:
  struct Hit {
    LidarPoint point;  // time_offset_s unset until the sweep is closed
    int64_t utime_us = 0;
  };

  // Reads one packet and sorts its hits into sweeps; false at the end of the file.
  bool read_packet();
  void add_hit(const Hit& hit);
  // Emits the hits before `end` as one sweep; the rest start the next one.
  void close_sweep(size_t end);

  std::string hits_path_;
  std::string ground_truth_path_;
  NcltConfig config_;
  std::ifstream hits_;
  uint64_t hits_size_bytes_ = 0;
  uint64_t hits_offset_ = 0;
  std::unique_ptr<TextLineReader> imu_;
  std::optional<int64_t> last_packet_utime_us_;
  std::vector<Hit> sweep_;
  std::optional<double> last_phase_rad_;
  std::deque<LidarScan> closed_sweeps_;
  bool hits_ended_ = false;
  std::vector<uint8_t> packet_buffer_;
};

}  // namespace liloc::dataset
