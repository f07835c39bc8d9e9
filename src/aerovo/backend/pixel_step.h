// A frame pair's fitted pixel transform as a relative factor of the pose graph (pose_graph.h):
// the measurement prev_from_curr in the frames' ground coordinates (similarity2.h) and the
// information matrix of a similarity fit on the pair's inlier points.
//
// Frames: pixel frame of a frame, x right (columns), y down (rows), (0, 0) = the centre of the
// top-left pixel (odometry/pose_chain.h); the frame's ground coordinates (similarity2.h), x =
// image right, y = image up, metres, origin at the camera centre's ground point `centre_px`:
//   p_m = gsd_m_per_px * (p_px.x - centre.x, centre.y - p_px.y).
#pragma once

#include <Eigen/Core>

#include "aerovo/backend/similarity2.h"

namespace aerovo::backend {

/// prev_from_curr in ground coordinates from the odometry's step `curr_from_prev_px` (3x3, maps
/// frame prev's pixels to frame curr's, FrameResult::curr_from_prev; an affine transform is
/// reduced to its closest similarity: the rotation of its polar decomposition and sqrt|det| as
/// the scale, as PoseChain does). `centre_px`: the camera centre's pixel (the image centre,
/// ((width - 1) / 2, (height - 1) / 2)); gsd: each frame's ground sampling distance, metres per
/// pixel (> 0). The translation is where frame curr's centre lies in frame prev's metres, the
/// log-scale log(gsd_prev / gsd_curr) + log sqrt|det| (0 when the heights explain the zoom).
/// Throws InvalidArgument for a singular or non-finite transform or a gsd not finite and > 0.
Similarity2 PrevFromCurrOfPixelStep(const Eigen::Matrix3d& curr_from_prev_px,
                                    const Eigen::Vector2d& centre_px, double gsd_prev_m_per_px,
                                    double gsd_curr_m_per_px);

/// The inverse of PrevFromCurrOfPixelStep for a similarity: the pixel transform
/// curr_from_prev_px (3x3, maps frame prev's pixels to frame curr's) of the ground-plane step
/// `prev_from_curr` between frames of the given ground sampling distances (e.g. a pair's
/// predicted step as a matching prior). Throws InvalidArgument for a step that is not finite or
/// a gsd not finite and > 0.
Eigen::Matrix3d PixelStepOfPrevFromCurr(const Similarity2& prev_from_curr,
                                        const Eigen::Vector2d& centre_px, double gsd_prev_m_per_px,
                                        double gsd_curr_m_per_px);

/// The information matrix (inverse covariance of x, y [frame prev's metres], heading [rad],
/// log-scale) of a least-squares similarity fit of the step `prev_from_curr` (ground
/// coordinates, as PrevFromCurrOfPixelStep gives) on inlier pairs whose frame-curr points are
/// `curr_px` (one column each), each point of a pair (in frame prev and in frame curr) noisy with
/// standard deviation `point_sigma_px` per axis in its image: J'J / sigma^2, J the derivative of
/// the predicted frame-prev points with respect to the measurement's parameters, sigma^2 =
/// point_sigma^2 (gsd_prev^2 + exp(2 log_scale) gsd_curr^2) (both points' noise in frame prev's
/// metres). First-order and for independent point errors: the error of a fit that extrapolates
/// a local cell to the frame, or of points that are not on a plane, is not in it; scale it (or
/// point_sigma_px, e.g. the fit's inlier RMS) up for that. Throws InvalidArgument for fewer than
/// 2 points, non-finite points or fit, or a sigma or gsd not finite and > 0; the result is
/// positive definite when the points are not all at one place.
Eigen::Matrix4d SimilarityFitInformation(const Eigen::Matrix2Xd& curr_px,
                                         const Similarity2& prev_from_curr,
                                         const Eigen::Vector2d& centre_px, double gsd_prev_m_per_px,
                                         double gsd_curr_m_per_px, double point_sigma_px);

}  // namespace aerovo::backend
