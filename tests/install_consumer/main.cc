// A tiny program built against the installed aerovo package (with find_package(aerovo) and with
// pkg-config): prints the version and runs SURF on a synthetic image.
#include <aerovo/features/surf.h>
#include <aerovo/version.h>

#include <cmath>
#include <cstdio>

int main() {
  aerovo::GrayImage image(320, 240, 60);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const double d2 = (x - 160.0) * (x - 160.0) + (y - 120.0) * (y - 120.0);
      image.at(x, y) = static_cast<std::uint8_t>(60 + 180 * std::exp(-d2 / (2 * 6.0 * 6.0)));
    }
  }
  aerovo::Surf surf;
  const aerovo::SurfResult result = surf.DetectAndDescribe(image.view());
  std::printf("aerovo %s, keypoints: %zu\n", aerovo::kVersion, result.features.size());
  return result.features.empty() ? 1 : 0;
}
