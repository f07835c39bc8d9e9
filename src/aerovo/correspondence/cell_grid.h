// The cell grid of clustered RANSAC (steps 2 and 3 of correspondence.h): the crop of the prev
// frame that the repeated motion keeps in view, its rows x cols equal cells, and the cell of
// every prev point. Pixel frame of features/keypoint.h; every size and edge in prev pixels.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "aerovo/core/image.h"
#include "aerovo/features/keypoint.h"

namespace aerovo {

/// The crop of clustered RANSAC step 2 for a width x height prev frame, given the previous
/// step's transform last_curr_from_prev (see correspondence.h). Throws InvalidArgument on a
/// non-positive size or a non-finite transform. Returns an empty rectangle when the motion
/// exceeds the frame.
RectI ClusteredCrop(int width, int height, const Eigen::Matrix3d& last_curr_from_prev);

/// Rectangle of cell (row, col) of a rows x cols split of `crop`, as [x0, x1) x [y0, y1) in
/// prev pixels (cells are equal, so their edges need not be whole pixels).
struct CellBounds {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool contains(double x, double y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};
CellBounds ClusterCellBounds(const RectI& crop, int rows, int cols, int row, int col);

/// The cell of every prev point in a rows x cols split of a crop, with its buffers kept between
/// frame pairs (no allocation in steady state). A point belongs to the cell whose
/// ClusterCellBounds contain it (the same edges, bit for bit), to none outside the crop.
class CellAssignment {
 public:
  /// Assigns every point of `prev`; `counts` becomes the points per cell, row-major, rows * cols
  /// entries. Preconditions: rows >= 1, cols >= 1.
  void Assign(const FeatureSet& prev, const RectI& crop, int rows, int cols,
              std::vector<int>* counts);
  /// cell_of()[i]: row-major cell of prev point i of the last Assign, -1 outside the crop.
  const std::vector<int>& cell_of() const { return cell_of_; }

 private:
  std::vector<int> cell_of_;
  std::vector<double> edges_x_, edges_y_;  // inner cell edges, px
};

}  // namespace aerovo
