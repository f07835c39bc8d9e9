// A compact global descriptor of a keyframe for loop-closure candidates (odometry/flight_graph.h,
// docs/backend.md "Loop closures"): the frame's SURF descriptors quantised into words, and the
// L2-normalised histogram of those words (a bag of words: J. Sivic, A. Zisserman, "Video Google:
// a text retrieval approach to object matching in videos", ICCV 2003). Two frames of the same
// ground share many words whatever their poses; the similarity of two signatures is the cosine
// of their histograms, in [0, 1].
//
// Words without a trained vocabulary: each word is `bits` signs of random projections
// (locality-sensitive hashing with random hyperplanes: M. S. Charikar, "Similarity estimation
// techniques from rounding algorithms", STOC 2002), the projection directions drawn from a seed
// and each one's threshold the median of the projections of the first frame's descriptors
// (SURF descriptors are not centred: their |dx|, |dy| sums are all positive, so hyperplanes
// through the origin would put nearly every descriptor on the same side). Nearby descriptors
// (the same ground point seen twice) mostly fall in the same word; the flight's first keyframe
// decides the thresholds, so the words are the same online and offline.
#pragma once

#include <cstdint>
#include <vector>

#include "aerovo/features/keypoint.h"

namespace aerovo {

/// The quantiser of descriptors into words (see the file comment).
class DescriptorQuantizer {
 public:
  /// `bits` projections (1..24: 2^bits words) of descriptors of `first.descriptor_size` values,
  /// directions drawn from `seed`, thresholds the medians over `first`'s descriptors (all zero
  /// when `first` is empty). InvalidArgument for bits out of range or a descriptor size < 1.
  DescriptorQuantizer(const FeatureSet& first, int bits, std::uint64_t seed);

  int bits() const { return bits_; }
  int descriptor_size() const { return size_; }
  /// The word of one descriptor of descriptor_size() values.
  std::uint32_t Word(const float* descriptor) const;

 private:
  int bits_ = 0, size_ = 0;
  std::vector<float> directions_;  // bits_ rows of size_ values
  std::vector<float> thresholds_;  // one per row
};

/// A keyframe's signature: the histogram of its descriptors' words, each bin the square root of
/// its count (a word repeated by a repetitive texture counts less: "burstiness", H. Jegou, M.
/// Douze, C. Schmid, "On the burstiness of visual elements", CVPR 2009), L2-normalised; sparse:
/// the non-zero bins as (word, weight), words ascending (empty for a frame without descriptors).
struct PlaceSignature {
  std::vector<std::uint32_t> words;
  std::vector<float> weights;
  bool empty() const { return words.empty(); }
};

/// The signature of `features` (descriptor_size must equal the quantiser's: InvalidArgument
/// otherwise).
PlaceSignature SignatureOf(const DescriptorQuantizer& quantizer, const FeatureSet& features);

/// The cosine of two signatures of the same quantiser, in [0, 1] (0 when either is empty): a
/// merge of the two word lists, O(size of both).
double Similarity(const PlaceSignature& a, const PlaceSignature& b);

}  // namespace aerovo
