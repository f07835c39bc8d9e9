#include "aerovo/correspondence/cell_grid.h"

#include <cmath>
#include <string>

#include "aerovo/core/error.h"
#include "aerovo/estimation/models.h"

namespace aerovo {

RectI ClusteredCrop(int width, int height, const Eigen::Matrix3d& last_curr_from_prev) {
  if (width <= 0 || height <= 0) {
    throw InvalidArgument("ClusteredCrop: frame size must be positive, got " +
                          std::to_string(width) + " x " + std::to_string(height));
  }
  if (!last_curr_from_prev.allFinite()) {
    throw InvalidArgument("ClusteredCrop: the previous step's transform has non-finite entries");
  }
  const Eigen::Vector2d centre(0.5 * (width - 1), 0.5 * (height - 1));
  const Eigen::Vector2d moved = TransformPoint(last_curr_from_prev, centre);
  const double tu = moved.x() - centre.x();
  const double tv = moved.y() - centre.y();
  if (!std::isfinite(tu) || !std::isfinite(tv)) return RectI{0, 0, 0, 0};
  // Rounding up drops every point that the repeated motion would push out of the frame; a
  // sub-millipixel shift is numerical noise of a zero motion, not a strip.
  auto strip = [](double t, int size) {
    const double a = std::abs(t);
    if (a < 1e-3) return 0;
    return a >= size ? size : static_cast<int>(std::ceil(a));
  };
  const int su = strip(tu, width);
  const int sv = strip(tv, height);
  RectI crop{0, 0, width - su, height - sv};
  if (tu < 0) crop.x = su;  // Content moves left: the left strip leaves the view.
  if (tv < 0) crop.y = sv;  // Content moves up: the top strip leaves the view.
  if (crop.empty()) return RectI{crop.x, crop.y, 0, 0};
  return crop;
}

CellBounds ClusterCellBounds(const RectI& crop, int rows, int cols, int row, int col) {
  const double cw = static_cast<double>(crop.width) / cols;
  const double ch = static_cast<double>(crop.height) / rows;
  CellBounds b;
  b.x0 = crop.x + col * cw;
  b.x1 = col + 1 == cols ? crop.x + crop.width : crop.x + (col + 1) * cw;
  b.y0 = crop.y + row * ch;
  b.y1 = row + 1 == rows ? crop.y + crop.height : crop.y + (row + 1) * ch;
  return b;
}

void CellAssignment::Assign(const FeatureSet& prev, const RectI& crop, int rows, int cols,
                            std::vector<int>* counts_out) {
  counts_out->assign(static_cast<std::size_t>(rows * cols), 0);
  cell_of_.assign(prev.size(), -1);
  if (crop.empty()) return;
  // A point's column is the number of inner cell edges at or left of it, with the edges
  // computed as ClusterCellBounds computes them: the two agree on every edge, and two
  // comparisons per axis cost less than the divisions they replace (the loop runs over
  // every prev point of every pair).
  const double cw = static_cast<double>(crop.width) / cols;
  const double ch = static_cast<double>(crop.height) / rows;
  edges_x_.resize(static_cast<std::size_t>(cols - 1));
  edges_y_.resize(static_cast<std::size_t>(rows - 1));
  for (int k = 1; k < cols; ++k) edges_x_[static_cast<std::size_t>(k - 1)] = crop.x + k * cw;
  for (int k = 1; k < rows; ++k) edges_y_[static_cast<std::size_t>(k - 1)] = crop.y + k * ch;
  const double x0 = crop.x, x1 = static_cast<double>(crop.x) + crop.width;
  const double y0 = crop.y, y1 = static_cast<double>(crop.y) + crop.height;
  const double* ex = edges_x_.data();
  const double* ey = edges_y_.data();
  const int nex = cols - 1, ney = rows - 1;
  const Keypoint* kps = prev.keypoints.data();
  int* out_cell = cell_of_.data();
  int* counts = counts_out->data();
  const int n = static_cast<int>(prev.size());
  for (int i = 0; i < n; ++i) {
    const double x = kps[i].x, y = kps[i].y;
    if (!(x >= x0 && x < x1 && y >= y0 && y < y1)) continue;  // RectI::contains
    int c = 0, r = 0;
    for (int e = 0; e < nex; ++e) c += x >= ex[e] ? 1 : 0;
    for (int e = 0; e < ney; ++e) r += y >= ey[e] ? 1 : 0;
    out_cell[i] = r * cols + c;
    ++counts[r * cols + c];
  }
}

}  // namespace aerovo
