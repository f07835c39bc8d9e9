// The clustered search of CorrespondenceStage (steps 1-5 of correspondence.h): the crop and
// cells of the prev frame, the eligible cells in order, one match + RANSAC attempt per cell
// until one succeeds (then the refinement, step 6), else the standard method on all points.
#include <algorithm>
#include <vector>

#include "aerovo/core/timer.h"
#include "aerovo/correspondence/correspondence.h"

namespace aerovo {

namespace {

// Cells with at least min_points points, in the order they are tried (step 4): by point count
// (CellOrder), ties in row-major order.
void EligibleCellsInOrder(const ClusteredRansacOptions& co, const std::vector<int>& counts,
                          std::vector<int>* order) {
  order->clear();
  for (int cell = 0; cell < co.grid_rows * co.grid_cols; ++cell) {
    if (counts[static_cast<std::size_t>(cell)] >= co.min_points) order->push_back(cell);
  }
  std::stable_sort(order->begin(), order->end(), [&](int a, int b) {
    return co.cell_order == CellOrder::kFewestFirst ? counts[a] < counts[b] : counts[a] > counts[b];
  });
}

}  // namespace

CorrespondenceResult CorrespondenceStage::Clustered(const FeatureSet& prev, int prev_width,
                                                    int prev_height, const FeatureSet& curr,
                                                    const Eigen::Matrix3d& last_curr_from_prev) {
  Stopwatch total;
  const ClusteredRansacOptions& co = options_.clustered;
  CorrespondenceResult result;
  result.method_used = CorrespondenceMethod::kClustered;
  // Clustered RANSAC matches curr up to grid_rows * grid_cols + 2 times: prepare it once.
  fit_.Prepare(curr, &result);
  result.crop = co.crop ? ClusteredCrop(prev_width, prev_height, last_curr_from_prev)
                        : ClusteredCrop(prev_width, prev_height, Eigen::Matrix3d::Identity());
  const int cols = co.grid_cols;
  cells_.Assign(prev, result.crop, co.grid_rows, cols, &result.cell_point_counts);
  const std::vector<int>& cell_of = cells_.cell_of();
  EligibleCellsInOrder(co, result.cell_point_counts, &cell_order_);

  for (int cell : cell_order_) {
    subset_.clear();
    for (std::size_t i = 0; i < cell_of.size(); ++i) {
      if (cell_of[i] == cell) subset_.push_back(static_cast<int>(i));
    }
    if (fit_.Run(matcher_, options_.guided_matching, prev, subset_, last_curr_from_prev,
                 &result)) {
      result.cell_row = cell / cols;
      result.cell_col = cell % cols;
      if (co.refine) refinement_.RefineCell(options_, fit_, prev, prev_width, prev_height, cell_of,
                                            &result);
      result.total_ms = total.elapsed_ms();
      return result;
    }
  }

  // The linear-motion assumption failed for this step (the paper): standard RANSAC on all.
  result.fell_back = true;
  result.method_used = CorrespondenceMethod::kStandard;
  subset_.clear();
  fit_.Run(matcher_, options_.guided_matching, prev, subset_, last_curr_from_prev, &result);
  if (co.refine && co.refine_fallback && result.success) {
    refinement_.RefitOnAllPoints(fit_, prev, &result);
  }
  result.total_ms = total.elapsed_ms();
  return result;
}

}  // namespace aerovo
