#include "eval/trajectory_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

namespace liloc::eval {
namespace {
constexpr int kTitleHeightPx = 30;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.5;
const cv::Scalar kTextColor(0, 0, 0);

struct LegendEntry {
  std::string label;
  cv::Scalar color;
  int sample_width_px;  // the band is shown wide, lines thin
};

// Metres (x right, y up) to pixels, one scale for both axes.
struct View {
  double scale_px_per_m = 1.0;
  Eigen::Vector2d center_m = Eigen::Vector2d::Zero();
  cv::Point2d center_px;

  cv::Point to_px(const Eigen::Vector3d& p) const {
    return {static_cast<int>(std::lround(center_px.x + (p.x() - center_m.x()) * scale_px_per_m)),
            static_cast<int>(std::lround(center_px.y - (p.y() - center_m.y()) * scale_px_per_m))};
  }
};

View fit_view(const TrajectoryPlotInput& input, const TrajectoryPlotConfig& config) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  const auto extend = [&](const Trajectory& trajectory, double pad_m) {
    for (const StampedPose& p : trajectory.poses()) {
      const Eigen::Vector2d xy = p.T.translation().head<2>();
      lo = lo.cwiseMin(xy - Eigen::Vector2d::Constant(pad_m));
      hi = hi.cwiseMax(xy + Eigen::Vector2d::Constant(pad_m));
    }
  };
  extend(input.ground_truth, 0.0);
  extend(input.estimate, 0.0);
  extend(input.mapped_area, config.mapped_area_radius_m);
  if (!(lo.array() <= hi.array()).all()) {
    throw std::invalid_argument("trajectory plot: nothing to draw");
  }
  // A single point or a straight axis-parallel line still gets a finite scale.
  const Eigen::Vector2d extent_m = (hi - lo).cwiseMax(1.0);
  const double width_px = config.width_px - 2.0 * config.margin_px;
  const double height_px = config.height_px - 2.0 * config.margin_px - kTitleHeightPx;
  View view;
  view.scale_px_per_m = std::min(width_px / extent_m.x(), height_px / extent_m.y());
  view.center_m = 0.5 * (lo + hi);
  view.center_px = {config.width_px / 2.0, kTitleHeightPx + config.margin_px + height_px / 2.0};
  return view;
}

cv::Scalar mode_color(const std::optional<int>& mode) {
  if (mode == kModeRlm) {
    return kRlmColor;
  }
  if (mode == kModeIlm) {
    return kIlmColor;
  }
  return kUnknownModeColor;
}

// Pixel polyline of a trajectory, leaving out points that land on the previous pixel
// (a dense trajectory would otherwise draw thousands of zero-length segments).
std::vector<std::pair<cv::Point, double>> to_pixels(const Trajectory& trajectory,
                                                    const View& view) {
  std::vector<std::pair<cv::Point, double>> points;
  for (const StampedPose& p : trajectory.poses()) {
    const cv::Point px = view.to_px(p.T.translation());
    if (points.empty() || px != points.back().first) {
      points.emplace_back(px, p.time_s);
    }
  }
  return points;
}

void draw_path(cv::Mat& canvas, const std::vector<std::pair<cv::Point, double>>& points,
               const cv::Scalar& color, int width_px) {
  for (size_t k = 1; k < points.size(); ++k) {
    cv::line(canvas, points[k - 1].first, points[k].first, color, width_px, cv::LINE_AA);
  }
}

void draw_mapped_area(cv::Mat& canvas, const TrajectoryPlotInput& input, const View& view,
                      const TrajectoryPlotConfig& config) {
  const auto points = to_pixels(input.mapped_area, view);
  if (points.empty()) {
    return;
  }
  // Drawn opaque on a copy, then blended, so overlapping passes do not darken the band.
  cv::Mat overlay = canvas.clone();
  const int radius_px =
      std::max(1, static_cast<int>(std::lround(config.mapped_area_radius_m * view.scale_px_per_m)));
  for (const auto& [px, time_s] : points) {
    cv::circle(overlay, px, radius_px, kMappedAreaColor, cv::FILLED, cv::LINE_AA);
  }
  draw_path(overlay, points, kMappedAreaColor, 2 * radius_px);
  cv::addWeighted(overlay, config.mapped_area_opacity, canvas, 1.0 - config.mapped_area_opacity,
                  0.0, canvas);
}

// 1, 2 or 5 times a power of ten, at most max_m.
double nice_length(double max_m) {
  const double power = std::pow(10.0, std::floor(std::log10(max_m)));
  for (const double step : {5.0, 2.0, 1.0}) {
    if (step * power <= max_m) {
      return step * power;
    }
  }
  return power;
}

std::string format_length(double metres) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g m", metres);
  return buffer;
}

void draw_legend(cv::Mat& canvas, const std::vector<LegendEntry>& entries,
                 const TrajectoryPlotConfig& config) {
  constexpr int kRowPx = 22;
  constexpr int kSamplePx = 30;
  int text_width_px = 0;
  for (const LegendEntry& entry : entries) {
    int baseline = 0;
    text_width_px = std::max(text_width_px,
                             cv::getTextSize(entry.label, kFont, kFontScale, 1, &baseline).width);
  }
  const int box_width_px = kSamplePx + text_width_px + 30;
  const cv::Point top_left(config.width_px - config.margin_px - box_width_px,
                           kTitleHeightPx + config.margin_px / 2);
  const cv::Rect box(top_left.x, top_left.y, box_width_px,
                     kRowPx * static_cast<int>(entries.size()) + 10);
  cv::rectangle(canvas, box, cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(canvas, box, cv::Scalar(160, 160, 160), 1);
  for (size_t k = 0; k < entries.size(); ++k) {
    const int y = top_left.y + 5 + kRowPx * static_cast<int>(k) + kRowPx / 2;
    cv::line(canvas, {top_left.x + 10, y}, {top_left.x + 10 + kSamplePx, y}, entries[k].color,
             entries[k].sample_width_px);
    cv::putText(canvas, entries[k].label, {top_left.x + 20 + kSamplePx, y + 5}, kFont, kFontScale,
                kTextColor, 1, cv::LINE_AA);
  }
}
}  // namespace

void TrajectoryPlotConfig::validate() const {
  constexpr int kMinPlotPx = 100;
  if (margin_px < 0 || width_px - 2 * margin_px < kMinPlotPx ||
      height_px - 2 * margin_px - kTitleHeightPx < kMinPlotPx) {
    throw std::invalid_argument(
        "trajectory plot: width_px, height_px and margin_px must leave at least 100 x 100 px "
        "to plot in");
  }
  if (line_width_px < 1) {
    throw std::invalid_argument("trajectory plot: line_width_px must be >= 1");
  }
  if (!(mapped_area_radius_m > 0.0)) {
    throw std::invalid_argument("trajectory plot: mapped_area_radius_m must be > 0");
  }
  if (!(mapped_area_opacity >= 0.0 && mapped_area_opacity <= 1.0)) {
    throw std::invalid_argument("trajectory plot: mapped_area_opacity must be in [0, 1]");
  }
}

cv::Mat render_trajectory_plot(const TrajectoryPlotInput& input,
                               const TrajectoryPlotConfig& config) {
  config.validate();
  const View view = fit_view(input, config);
  cv::Mat canvas(config.height_px, config.width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<LegendEntry> legend;

  if (!input.mapped_area.empty()) {
    draw_mapped_area(canvas, input, view, config);
    // The swatch shows the band as it appears: blended over the white background.
    const cv::Scalar band_color = kMappedAreaColor * config.mapped_area_opacity +
                                  cv::Scalar::all(255.0 * (1.0 - config.mapped_area_opacity));
    legend.push_back(
        {"mapped area (" + format_length(config.mapped_area_radius_m) + ")", band_color, 10});
  }
  if (!input.ground_truth.empty()) {
    draw_path(canvas, to_pixels(input.ground_truth, view), kGroundTruthColor, config.line_width_px);
    legend.push_back({"ground truth", kGroundTruthColor, 3});
  }
  // Each segment takes the mode at its start; only colours that occur enter the legend.
  bool used_rlm = false, used_ilm = false, used_unknown = false;
  const auto estimate_px = to_pixels(input.estimate, view);
  for (size_t k = 1; k < estimate_px.size(); ++k) {
    const std::optional<int> mode = input.modes.mode_at(estimate_px[k - 1].second);
    const cv::Scalar color = mode_color(mode);
    used_rlm = used_rlm || mode == kModeRlm;
    used_ilm = used_ilm || mode == kModeIlm;
    used_unknown = used_unknown || (mode != kModeRlm && mode != kModeIlm);
    cv::line(canvas, estimate_px[k - 1].first, estimate_px[k].first, color, config.line_width_px,
             cv::LINE_AA);
  }
  if (used_rlm) {
    legend.push_back({"estimate, RLM", kRlmColor, 3});
  }
  if (used_ilm) {
    legend.push_back({"estimate, ILM", kIlmColor, 3});
  }
  if (used_unknown) {
    legend.push_back(
        {input.modes.empty() ? "estimate" : "estimate, other mode", kUnknownModeColor, 3});
  }

  draw_scale_bar(canvas, {config.margin_px, config.height_px - config.margin_px / 2},
                 config.width_px - 2.0 * config.margin_px, view.scale_px_per_m, kTextColor);
  draw_legend(canvas, legend, config);
  cv::putText(canvas, input.title, {config.margin_px / 2, kTitleHeightPx - 8}, kFont, kFontScale,
              kTextColor, 1, cv::LINE_AA);
  return canvas;
}

void draw_scale_bar(cv::Mat& canvas, cv::Point left, double plot_width_px, double px_per_m,
                    const cv::Scalar& color) {
  const double length_m = nice_length(0.25 * plot_width_px / px_per_m);
  const int length_px = static_cast<int>(std::lround(length_m * px_per_m));
  const cv::Point right = left + cv::Point(length_px, 0);
  cv::line(canvas, left, right, color, 2);
  cv::line(canvas, left - cv::Point(0, 5), left + cv::Point(0, 5), color, 2);
  cv::line(canvas, right - cv::Point(0, 5), right + cv::Point(0, 5), color, 2);
  cv::putText(canvas, format_length(length_m), left + cv::Point(0, -10), kFont, kFontScale, color,
              1, cv::LINE_AA);
}

}  // namespace liloc::eval
