// A float image in memory: row-major, channels interleaved, linear values.
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <vector>

namespace shadowsg {

struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> data;

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f)
      : width(w), height(h), channels(c), data(static_cast<size_t>(w) * h * c, fill) {}

  bool empty() const { return data.empty(); }
  size_t pixels() const { return static_cast<size_t>(width) * height; }
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }

  float& at(int x, int y, int c) { return data[index(x, y) * channels + c]; }
  float at(int x, int y, int c) const { return data[index(x, y) * channels + c]; }

  // RGB of a pixel; a 1-channel image repeats its value.
  Eigen::Vector3f rgb(size_t pixel) const {
    const float* p = &data[pixel * channels];
    return channels >= 3 ? Eigen::Vector3f(p[0], p[1], p[2]) : Eigen::Vector3f::Constant(p[0]);
  }
  void set_rgb(size_t pixel, const Eigen::Vector3f& v) {
    float* p = &data[pixel * channels];
    for (int c = 0; c < channels && c < 3; ++c) p[c] = v[c];
  }
};

}  // namespace shadowsg
