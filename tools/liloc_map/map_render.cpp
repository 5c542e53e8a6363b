#include "liloc_map/map_render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "eval/trajectory_plot.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc::tools {
namespace {

constexpr int kMarginPx = 50;
constexpr int kTitleHeightPx = 30;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.5;
const cv::Scalar kTextColor(0, 0, 0);
const cv::Scalar kBackgroundColor(255, 255, 255);
const cv::Scalar kGreyPointColor(110, 110, 110);
const cv::Scalar kSubmapColor(200, 120, 0);  // blue, BGR
// Session paths, BGR: red, green, orange, magenta, cyan, brown.
const cv::Scalar kSessionColors[] = {{40, 40, 220},  {40, 160, 40}, {0, 140, 255},
                                     {180, 40, 180}, {200, 180, 0}, {40, 80, 140}};
// Heights are mapped between these quantiles of the cells, so a few outliers (a crane, a
// pit) do not flatten the colours of everything else.
constexpr double kLowHeightQuantile = 0.02;
constexpr double kHighHeightQuantile = 0.98;

// Map metres (x right, y up) to pixels of the image.
struct View {
  double px_per_m;
  int min_cell_x;
  int max_cell_y;
  cv::Point to_px(double x_m, double y_m) const {
    return {kMarginPx + static_cast<int>(std::floor(x_m * px_per_m)) - min_cell_x,
            kTitleHeightPx + kMarginPx + max_cell_y - static_cast<int>(std::floor(y_m * px_per_m))};
  }
};

// Colour bar of the height range at the bottom right.
void draw_height_legend(cv::Mat& canvas, float low_m, float high_m) {
  constexpr int kWidthPx = 150;
  constexpr int kHeightPx = 10;
  cv::Mat ramp(1, kWidthPx, CV_8UC1);
  for (int i = 0; i < kWidthPx; ++i) {
    ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(255 * i / (kWidthPx - 1));
  }
  cv::Mat coloured;
  cv::applyColorMap(ramp, coloured, cv::COLORMAP_VIRIDIS);
  cv::resize(coloured, coloured, {kWidthPx, kHeightPx}, 0, 0, cv::INTER_NEAREST);
  const cv::Point origin(canvas.cols - kMarginPx - kWidthPx, canvas.rows - kMarginPx / 2 - 5);
  if (origin.x < kMarginPx + 200) {
    return;  // no room next to the scale bar
  }
  coloured.copyTo(canvas(cv::Rect(origin.x, origin.y, kWidthPx, kHeightPx)));
  char text[64];
  std::snprintf(text, sizeof(text), "z %.1f .. %.1f m", low_m, high_m);
  cv::putText(canvas, text, origin + cv::Point(0, -8), kFont, kFontScale, kTextColor, 1,
              cv::LINE_AA);
}

void draw_legend(cv::Mat& canvas, const std::vector<std::pair<std::string, cv::Scalar>>& entries) {
  constexpr int kRowPx = 22;
  constexpr int kSamplePx = 30;
  int text_width_px = 0;
  for (const auto& entry : entries) {
    int baseline = 0;
    text_width_px = std::max(text_width_px,
                             cv::getTextSize(entry.first, kFont, kFontScale, 1, &baseline).width);
  }
  const int box_width_px = kSamplePx + text_width_px + 30;
  const cv::Rect box(canvas.cols - kMarginPx - box_width_px, kTitleHeightPx + kMarginPx / 2,
                     box_width_px, kRowPx * static_cast<int>(entries.size()) + 10);
  cv::rectangle(canvas, box, kBackgroundColor, cv::FILLED);
  cv::rectangle(canvas, box, cv::Scalar(160, 160, 160), 1);
  for (size_t k = 0; k < entries.size(); ++k) {
    const int y = box.y + 5 + kRowPx * static_cast<int>(k) + kRowPx / 2;
    cv::line(canvas, {box.x + 10, y}, {box.x + 10 + kSamplePx, y}, entries[k].second, 3);
    cv::putText(canvas, entries[k].first, {box.x + 20 + kSamplePx, y + 5}, kFont, kFontScale,
                kTextColor, 1, cv::LINE_AA);
  }
}

}  // namespace

void MapRenderConfig::validate() const {
  if (!(px_per_m > 0.0) || !std::isfinite(px_per_m)) {
    throw std::invalid_argument("render: px_per_m must be > 0");
  }
  if (max_side_px < 2 * kMarginPx + 100) {
    throw std::invalid_argument("render: max_side_px must be at least 200");
  }
}

MapRenderer::MapRenderer(const MapRenderConfig& config) : config_(config) { config_.validate(); }

void MapRenderer::add_cloud(const PointCloud& cloud_body, const Eigen::Isometry3d& T_map_body) {
  const Eigen::Affine3f T = Eigen::Affine3f(T_map_body.cast<float>());
  const float cell_m = static_cast<float>(1.0 / config_.px_per_m);
  for (const Eigen::Vector3f& p_body : cloud_body.points) {
    const Eigen::Vector3f p = T * p_body;
    const Eigen::Vector3i index = voxel_index(Eigen::Vector3f(p.x(), p.y(), 0.0f), cell_m);
    const auto [slot, inserted] = cell_index_.insert(voxel_key(index));
    if (inserted) {
      cells_.push_back({index.x(), index.y(), p.z()});
    } else {
      cells_[slot].max_z_m = std::max(cells_[slot].max_z_m, p.z());
    }
  }
}

cv::Mat MapRenderer::render(const MapData& map, const std::string& title) const {
  // Extent: every point and keyframe, in cells of the image.
  int min_x = std::numeric_limits<int>::max(), max_x = std::numeric_limits<int>::min();
  int min_y = min_x, max_y = max_x;
  const auto extend = [&](int x, int y) {
    min_x = std::min(min_x, x);
    max_x = std::max(max_x, x);
    min_y = std::min(min_y, y);
    max_y = std::max(max_y, y);
  };
  for (const Cell& cell : cells_) {
    extend(cell.x, cell.y);
  }
  for (const MapKeyframe& kf : map.keyframes) {
    extend(static_cast<int>(std::floor(kf.T_map_body.translation().x() * config_.px_per_m)),
           static_cast<int>(std::floor(kf.T_map_body.translation().y() * config_.px_per_m)));
  }
  if (min_x > max_x) {
    throw std::invalid_argument("render: the map has no points and no keyframes");
  }
  const int64_t width_px = int64_t{max_x} - min_x + 1 + 2 * kMarginPx;
  const int64_t height_px = int64_t{max_y} - min_y + 1 + 2 * kMarginPx + kTitleHeightPx;
  if (width_px > config_.max_side_px || height_px > config_.max_side_px) {
    throw std::invalid_argument("render: the image would be " + std::to_string(width_px) + " x " +
                                std::to_string(height_px) + " px (at most " +
                                std::to_string(config_.max_side_px) +
                                " per side): lower --px-per-m");
  }
  const View view{config_.px_per_m, min_x, max_y};
  cv::Mat canvas(static_cast<int>(height_px), static_cast<int>(width_px), CV_8UC3,
                 kBackgroundColor);

  // Points: the highest point of each cell, coloured by its height.
  float low_z_m = 0.0f, high_z_m = 0.0f;
  if (!cells_.empty()) {
    std::vector<float> heights;
    heights.reserve(cells_.size());
    for (const Cell& cell : cells_) {
      heights.push_back(cell.max_z_m);
    }
    const auto quantile = [&](double q) {
      const size_t k = static_cast<size_t>(q * static_cast<double>(heights.size() - 1));
      std::nth_element(heights.begin(), heights.begin() + static_cast<std::ptrdiff_t>(k),
                       heights.end());
      return heights[k];
    };
    low_z_m = quantile(kLowHeightQuantile);
    high_z_m = std::max(quantile(kHighHeightQuantile), low_z_m + 0.1f);
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) {
      ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
    }
    cv::Mat palette;
    cv::applyColorMap(ramp, palette, cv::COLORMAP_VIRIDIS);
    for (const Cell& cell : cells_) {
      const cv::Point px(kMarginPx + cell.x - min_x, kTitleHeightPx + kMarginPx + max_y - cell.y);
      const float t = std::clamp((cell.max_z_m - low_z_m) / (high_z_m - low_z_m), 0.0f, 1.0f);
      canvas.at<cv::Vec3b>(px) =
          config_.height_colours
              ? palette.at<cv::Vec3b>(0, static_cast<int>(std::lround(t * 255.0f)))
              : cv::Vec3b(static_cast<uint8_t>(kGreyPointColor[0]),
                          static_cast<uint8_t>(kGreyPointColor[1]),
                          static_cast<uint8_t>(kGreyPointColor[2]));
    }
  }

  // Submap bounds with their ids.
  for (const Submap& submap : map.submaps) {
    const cv::Point top_left = view.to_px(submap.bounds.min_x, submap.bounds.max_y);
    const cv::Point bottom_right = view.to_px(submap.bounds.max_x, submap.bounds.min_y);
    cv::rectangle(canvas, top_left, bottom_right, kSubmapColor, 1, cv::LINE_AA);
    cv::putText(canvas, std::to_string(submap.id), top_left + cv::Point(3, 14), kFont,
                0.8 * kFontScale, kSubmapColor, 1, cv::LINE_AA);
  }

  // Keyframe paths, one colour per session, joined between consecutive keyframes of a
  // session.
  std::map<std::string, cv::Scalar> session_colors;
  std::map<std::string, cv::Point> last_px;
  for (const MapKeyframe& kf : map.keyframes) {
    const auto [it, is_new] = session_colors.emplace(
        kf.session, kSessionColors[session_colors.size() % std::size(kSessionColors)]);
    const cv::Point px =
        view.to_px(kf.T_map_body.translation().x(), kf.T_map_body.translation().y());
    if (!is_new) {
      cv::line(canvas, last_px[kf.session], px, it->second, 2, cv::LINE_AA);
    }
    cv::circle(canvas, px, 2, it->second, cv::FILLED, cv::LINE_AA);
    last_px[kf.session] = px;
  }

  std::vector<std::pair<std::string, cv::Scalar>> legend;
  for (const auto& [session, color] : session_colors) {
    legend.emplace_back("keyframes, session " + (session.empty() ? "(unnamed)" : session), color);
  }
  legend.emplace_back("submap bounds (id)", kSubmapColor);
  draw_legend(canvas, legend);
  eval::draw_scale_bar(canvas, {kMarginPx, canvas.rows - kMarginPx / 2},
                       canvas.cols - 2.0 * kMarginPx, config_.px_per_m, kTextColor);
  if (config_.height_colours && !cells_.empty()) {
    draw_height_legend(canvas, low_z_m, high_z_m);
  }
  cv::putText(canvas, title, {kMarginPx / 2, kTitleHeightPx - 8}, kFont, kFontScale, kTextColor, 1,
              cv::LINE_AA);
  return canvas;
}

}  // namespace liloc::tools
