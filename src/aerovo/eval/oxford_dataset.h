// Reading the Oxford affine-covariant regions benchmark (Mikolajczyk et al., "A comparison of
// affine region detectors", IJCV 65(1/2), 2005; www.robots.ox.ac.uk/~vgg/research/affine):
// eight sequences (bark, bikes, boat, graf, leuven, trees, ubc, wall), each six images
// img1..img6 of a planar scene and homographies H1to2p..H1to6p mapping img1 to imgN.
// Layout expected, one folder per sequence as the benchmark is distributed: <dir>/img<N>.png (or
// .ppm/.pgm/.jpg) and <dir>/H1to<N>p, a 3x3 matrix as 9 numbers in row-major order,
// whitespace-separated.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace aerovo {

/// The eight standard sequence names, in the order the benchmark lists them.
const std::vector<std::string>& OxfordSequenceNames();

/// One Oxford sequence in memory.
struct OxfordSequence {
  std::string name;           ///< Folder name, e.g. "graf".
  std::filesystem::path dir;  ///< Folder it was read from.
  /// Grey images (CV_8UC1, converted from colour by OpenCV's BGR->grey weights).
  /// images[0] is img1; images[k] is img(targets[k-1]).
  std::vector<cv::Mat> images;
  /// Image numbers N loaded besides img1 (each in 2..6), in the order given to the loader.
  std::vector<int> targets;
  /// imgN_from_img1 homographies (pixel coordinates, (0,0) = centre of the top-left pixel, the
  /// convention OpenCV's evaluateFeatureDetector uses with these files): h_from_img1[k] maps
  /// img1 pixels to img(targets[k]) pixels. Normalised so that H(2,2) = 1.
  std::vector<cv::Matx33d> h_from_img1;
};

/// Reads a homography file (9 finite numbers, row-major, whitespace separated, nothing else).
/// Throws InputError naming the file and the problem (missing, unreadable, fewer or more than 9
/// numbers, a token that is not a number, singular matrix or H(2,2) = 0).
cv::Matx33d ReadOxfordHomography(const std::filesystem::path& file);

/// Reads img1, the images `targets` (each in 2..6) and their homographies H1to<N>p from `dir`.
/// Throws InvalidArgument for targets outside 2..6; InputError naming the missing or
/// malformed file (folder absent, image missing or not decodable, homography missing/bad).
OxfordSequence LoadOxfordSequence(const std::filesystem::path& dir,
                                  const std::vector<int>& targets = {2, 3, 4, 5, 6});

}  // namespace aerovo
