#pragma once
// Top-down (x-y) plot of an evaluated run: ground truth, the estimate coloured by
// localization mode, the mapped area shaded, with scale bar, legend and a title line.
// In its own library so that only its users compile against OpenCV.

#include <opencv2/core.hpp>
#include <string>

#include "eval/mode_timeline.hpp"
#include "math/trajectory.hpp"

namespace liloc::eval {

// Colours, BGR.
inline const cv::Scalar kGroundTruthColor(64, 64, 64);    // dark grey
inline const cv::Scalar kRlmColor(0, 160, 0);             // green
inline const cv::Scalar kIlmColor(0, 140, 255);           // orange
inline const cv::Scalar kUnknownModeColor(220, 100, 20);  // blue: odometry or no status
inline const cv::Scalar kMappedAreaColor(200, 150, 180);  // light purple, blended

struct TrajectoryPlotConfig {
  int width_px = 1200;
  int height_px = 900;
  int margin_px = 50;
  int line_width_px = 2;
  // The map covers roughly the LiDAR range around the mapping session's path.
  double mapped_area_radius_m = 30.0;
  double mapped_area_opacity = 0.35;

  // Throws std::invalid_argument naming the field if a value is out of range.
  void validate() const;
};

struct TrajectoryPlotInput {
  Trajectory ground_truth;
  Trajectory estimate;     // already in the ground-truth frame (T_gt_est applied)
  ModeTimeline modes;      // colours the estimate; empty: every pose "unknown"
  Trajectory mapped_area;  // e.g. session A's ground truth; empty: no shading
  std::string title;       // e.g. eval::summary_line()
};

// Renders the plot (CV_8UC3, config.height_px x config.width_px) with equal scale on
// both axes, fitted to everything drawn. Throws std::invalid_argument if the config is
// invalid or there is nothing to draw.
cv::Mat render_trajectory_plot(const TrajectoryPlotInput& input,
                               const TrajectoryPlotConfig& config);

// A scale bar of a round length (1, 2 or 5 x 10^k m, at most a quarter of the plot's
// width), its left end at `left`, labelled in metres. Shared by every top-down image.
void draw_scale_bar(cv::Mat& canvas, cv::Point left, double plot_width_px, double px_per_m,
                    const cv::Scalar& color);

}  // namespace liloc::eval
