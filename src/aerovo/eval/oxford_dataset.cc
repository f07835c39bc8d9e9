#include "aerovo/eval/oxford_dataset.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/text.h"
#include "aerovo/imageio/image_io.h"

namespace aerovo {
namespace fs = std::filesystem;

const std::vector<std::string>& OxfordSequenceNames() {
  static const std::vector<std::string> names = {"bark",   "bikes", "boat", "graf",
                                                 "leuven", "trees", "ubc",  "wall"};
  return names;
}

cv::Matx33d ReadOxfordHomography(const fs::path& file) {
  const std::string where = file.string();
  if (!fs::exists(file)) throw InputError(where + ": homography file not found");
  std::ifstream in(file);
  if (!in) throw InputError(where + ": cannot open homography file");
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    const std::optional<double> v = ParseDecimal(token);
    if (!v) {
      throw InputError(where + ": value " + std::to_string(values.size() + 1) + " ('" + token +
                       "') is not a finite number");
    }
    values.push_back(*v);
  }
  if (values.size() != 9) {
    throw InputError(where + ": expected 9 numbers (3x3 row-major homography), found " +
                     std::to_string(values.size()));
  }
  cv::Matx33d h(values.data());
  if (h(2, 2) == 0.0) throw InputError(where + ": H(2,2) is 0, cannot normalise the homography");
  h *= 1.0 / h(2, 2);
  if (std::abs(cv::determinant(h)) < 1e-12) {
    throw InputError(where + ": homography is singular");
  }
  return h;
}

namespace {

fs::path FindImage(const fs::path& dir, int n) {
  for (const char* ext : {".png", ".ppm", ".pgm", ".jpg"}) {
    fs::path p = dir / ("img" + std::to_string(n) + ext);
    if (fs::exists(p)) return p;
  }
  throw InputError((dir / ("img" + std::to_string(n) + ".png")).string() +
                   ": image not found (also tried .ppm, .pgm, .jpg)");
}

cv::Mat ReadGray(const fs::path& file) {
  cv::Mat img = imageio::Read(file.string(), cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw InputError(file.string() + ": cannot decode image");
  return img;
}

}  // namespace

OxfordSequence LoadOxfordSequence(const fs::path& dir, const std::vector<int>& targets) {
  for (int n : targets) {
    if (n < 2 || n > 6) {
      throw InvalidArgument("LoadOxfordSequence: target image " + std::to_string(n) +
                            " is outside 2..6");
    }
  }
  if (!fs::is_directory(dir)) {
    throw InputError(dir.string() + ": Oxford sequence folder not found");
  }
  OxfordSequence seq;
  seq.dir = dir;
  seq.name = dir.filename().string();
  if (seq.name.empty()) seq.name = dir.parent_path().filename().string();
  seq.targets = targets;
  seq.images.push_back(ReadGray(FindImage(dir, 1)));
  for (int n : targets) {
    seq.images.push_back(ReadGray(FindImage(dir, n)));
    seq.h_from_img1.push_back(ReadOxfordHomography(dir / ("H1to" + std::to_string(n) + "p")));
  }
  return seq;
}

}  // namespace aerovo
