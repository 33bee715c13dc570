#include "stages/io/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <half.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "calib/error.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

void RequireFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path.string(), "file not found");
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string(), "not a regular file");
  if (fs::file_size(path, ec) == 0) throw InputError(path.string(), "file is empty");
}

constexpr long kMaxPixels = 1L << 28;  // 268 M pixels: beyond any camera

}  // namespace

Image ReadExr(const fs::path& path, bool keep_alpha) {
  RequireFile(path);
  try {
    Imf::InputFile file(path.string().c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const long w = static_cast<long>(dw.max.x) - dw.min.x + 1;
    const long h = static_cast<long>(dw.max.y) - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w * h > kMaxPixels)
      throw InputError(path.string(), "unreasonable EXR size " + std::to_string(w) + "x" + std::to_string(h));
    // No EXR compression packs more than ~1000 pixels into a byte: a header
    // claiming more is corrupt, and the pixels are not allocated.
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(path, ec);
    if (!ec && static_cast<double>(w) * h > 1000.0 * static_cast<double>(bytes) + 65536)
      throw InputError(path.string(), "EXR header claims " + std::to_string(w) + "x" + std::to_string(h) +
                                          " pixels, more than a " + std::to_string(bytes) +
                                          "-byte file can hold (truncated or corrupt)");
    const Imf::ChannelList& ch = file.header().channels();
    std::vector<std::string> names;
    if (ch.findChannel("R") && ch.findChannel("G") && ch.findChannel("B")) {
      names = {"R", "G", "B"};
      if (keep_alpha && ch.findChannel("A")) names.push_back("A");
    } else if (ch.findChannel("Y")) {
      names = {"Y"};
    } else {
      throw InputError(path.string(), "EXR has neither R,G,B nor Y channels");
    }
    Image img(static_cast<int>(w), static_cast<int>(h), static_cast<int>(names.size()));
    Imf::FrameBuffer fb;
    const size_t xs = sizeof(float) * img.channels, ys = xs * w;
    char* base = reinterpret_cast<char*>(img.data.data()) - dw.min.x * static_cast<long>(xs) -
                 dw.min.y * static_cast<long>(ys);
    for (size_t c = 0; c < names.size(); ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys, 1, 1, 0.0));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path.string(), std::string("unreadable EXR: ") + e.what());
  }
}

namespace {

void WriteExrFile(const fs::path& path, const Image& image, ExrPixelType type, bool latlong_envmap) {
  SHADOWSG_CHECK(!image.empty());
  static const char* kRgba[] = {"R", "G", "B", "A"};
  const int nc = image.channels;
  WriteAtomically(path, [&](const fs::path& tmp) {
    try {
      Imf::Header header(image.width, image.height);
      header.compression() = Imf::ZIP_COMPRESSION;
      if (latlong_envmap) Imf::addEnvmap(header, Imf::ENVMAP_LATLONG);
      const Imf::PixelType pt = type == ExrPixelType::kHalf ? Imf::HALF : Imf::FLOAT;
      std::vector<std::string> names;
      if (nc == 1) names = {"Y"};
      else for (int c = 0; c < std::min(nc, 4); ++c) names.push_back(kRgba[c]);
      for (const auto& n : names) header.channels().insert(n, Imf::Channel(pt));
      // The frame buffer's pixel type must match the file's, so half output
      // goes through a converted copy.
      std::vector<half> halves;
      Imf::FrameBuffer fb;
      if (type == ExrPixelType::kHalf) {
        halves.assign(image.data.begin(), image.data.end());
        const size_t xs = sizeof(half) * nc, ys = xs * image.width;
        char* base = reinterpret_cast<char*>(halves.data());
        for (size_t c = 0; c < names.size(); ++c)
          fb.insert(names[c], Imf::Slice(Imf::HALF, base + c * sizeof(half), xs, ys));
      } else {
        const size_t xs = sizeof(float) * nc, ys = xs * image.width;
        char* base = const_cast<char*>(reinterpret_cast<const char*>(image.data.data()));
        for (size_t c = 0; c < names.size(); ++c)
          fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
      }
      Imf::OutputFile out(tmp.string().c_str(), header);
      out.setFrameBuffer(fb);
      out.writePixels(image.height);
    } catch (const std::exception& e) {
      throw InputError(path.string(), std::string("cannot write EXR: ") + e.what());
    }
  });
}

}  // namespace

void WriteExr(const fs::path& path, const Image& image, ExrPixelType type) {
  WriteExrFile(path, image, type, false);
}

void WriteLatLongExr(const fs::path& path, const Image& image) {
  SHADOWSG_CHECK(image.width == 2 * image.height);
  WriteExrFile(path, image, ExrPixelType::kFloat, true);
}

Image ReadEnvMapExr(const fs::path& path, EnvMapSign sign) {
  Image env = ReadExr(path);
  if (env.width != 2 * env.height)
    throw InputError(path.string(), "environment map must be twice as wide as high (is " + std::to_string(env.width) +
                                        "x" + std::to_string(env.height) + ")");
  for (float v : env.data) {
    if (!std::isfinite(v)) throw InputError(path.string(), "environment map has non-finite texels");
    if (v < 0 && sign == EnvMapSign::kNonNegative)
      throw InputError(path.string(), "environment map has negative texels");
  }
  return env;
}

bool ExrIsLatLong(const fs::path& path) {
  RequireFile(path);
  try {
    Imf::InputFile file(path.string().c_str());
    return Imf::hasEnvmap(file.header()) && Imf::envmap(file.header()) == Imf::ENVMAP_LATLONG;
  } catch (const std::exception& e) {
    throw InputError(path.string(), std::string("unreadable EXR: ") + e.what());
  }
}

namespace {

// Only PNG and JPEG get to OpenCV: imdecode picks a decoder by content, and
// some of those (GDCM's DICOM reader) abort the process on bad input (a
// fuzzer finding). libpng and libjpeg report a cut-off file on stderr
// themselves (and libjpeg then decodes the part it has); a PNG must end with
// its IEND chunk, a JPEG with an end-of-image marker, which we check first.
void CheckPngOrJpeg(const std::vector<unsigned char>& b, const fs::path& path) {
  auto tail_has = [&](const std::string& what, size_t tail) {
    const size_t from = b.size() > tail ? b.size() - tail : 0;
    return std::search(b.begin() + static_cast<long>(from), b.end(), what.begin(), what.end(),
                       [](unsigned char x, char y) { return x == static_cast<unsigned char>(y); }) != b.end();
  };
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (b.size() >= 8 && std::equal(kPng, kPng + 8, b.begin())) {
    if (!tail_has("IEND", 64)) throw InputError(path.string(), "truncated PNG (no IEND chunk at the end)");
  } else if (b.size() >= 2 && b[0] == 0xFF && b[1] == 0xD8) {
    if (!tail_has("\xFF\xD9", 4096)) throw InputError(path.string(), "truncated JPEG (no end-of-image marker)");
  } else {
    throw InputError(path.string(), "unreadable image: not a PNG or JPEG file (no PNG or JPEG signature)");
  }
}

}  // namespace

Image ReadLdr(const fs::path& path) {
  RequireFile(path);
  std::vector<unsigned char> bytes;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path.string(), "cannot open file");
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  CheckPngOrJpeg(bytes, path);
  cv::Mat m;
  try {
    m = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(path.string(), std::string("unreadable image: ") + e.what());
  }
  if (m.empty()) throw InputError(path.string(), "unreadable image (not a PNG/JPEG OpenCV can decode)");
  if (static_cast<double>(m.cols) * m.rows > kMaxPixels)
    throw InputError(path.string(), "unreasonable image size " + std::to_string(m.cols) + "x" + std::to_string(m.rows));
  double scale = 1.0;
  switch (m.depth()) {
    case CV_8U: scale = 1.0 / 255; break;
    case CV_16U: scale = 1.0 / 65535; break;
    case CV_32F: scale = 1.0; break;
    default: throw InputError(path.string(), "unsupported pixel depth");
  }
  if (m.channels() == 4) cv::cvtColor(m, m, cv::COLOR_BGRA2RGB);
  else if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2RGB);
  cv::Mat f;
  m.convertTo(f, CV_32F, scale);
  Image img(f.cols, f.rows, f.channels());
  for (int y = 0; y < f.rows; ++y)
    std::copy_n(f.ptr<float>(y), static_cast<size_t>(f.cols) * f.channels(), &img.data[img.index(0, y) * img.channels]);
  return img;
}

void WriteLdr(const fs::path& path, const Image& image) {
  cv::Mat m(image.height, image.width, CV_8UC(image.channels));
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < image.channels; ++c)
        m.ptr<unsigned char>(y)[x * image.channels + c] =
            static_cast<unsigned char>(std::lround(std::clamp(image.at(x, y, c), 0.0f, 1.0f) * 255));
  if (image.channels == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  if (image.channels == 4) cv::cvtColor(m, m, cv::COLOR_RGBA2BGRA);
  WriteAtomically(path, [&](const fs::path& tmp) {
    if (!cv::imwrite(tmp.string(), m)) throw InputError(path.string(), "cannot write image");
  });
}

Image ReadMask(const fs::path& path) {
  Image img = ReadLdr(path);
  Image mask(img.width, img.height, 1);
  for (size_t p = 0; p < mask.pixels(); ++p) {
    float any = 0;
    for (int c = 0; c < std::min(img.channels, 3); ++c) any = std::max(any, img.data[p * img.channels + c]);
    mask.data[p] = any > 0 ? 1.0f : 0.0f;
  }
  return mask;
}

Image ReadImage(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext == ".exr") return ReadExr(path);
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") return ReadLdr(path);
  throw InputError(path.string(), "unsupported image type '" + ext + "' (expected .exr, .png, .jpg)");
}

float SrgbEncode(float x) {
  x = std::max(0.0f, x);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

float SrgbDecode(float x) {
  return x <= 0.04045f ? x / 12.92f : std::pow((x + 0.055f) / 1.055f, 2.4f);
}

Image ToneMap(const Image& linear, float white) {
  if (white <= 0) {
    std::vector<float> v;
    v.reserve(linear.pixels());
    for (size_t p = 0; p < linear.pixels(); ++p) v.push_back(linear.rgb(p).maxCoeff());
    if (!v.empty()) {
      auto k = v.begin() + static_cast<long>(0.99 * (v.size() - 1));
      std::nth_element(v.begin(), k, v.end());
      white = *k;
    }
    if (!(white > 0) || !std::isfinite(white)) white = 1.0f;
  }
  Image out(linear.width, linear.height, std::min(linear.channels, 3));
  for (size_t i = 0; i < out.pixels(); ++i)
    for (int c = 0; c < out.channels; ++c) {
      const float x = linear.data[i * linear.channels + c] / white;
      out.data[i * out.channels + c] = std::isfinite(x) ? SrgbEncode(std::min(x, 1.0f)) : 0.0f;
    }
  return out;
}

void WritePreviewPng(const fs::path& path, const Image& linear, float white) {
  WriteLdr(path, ToneMap(linear, white));
}

void WriteExrWithPreview(const fs::path& path, const Image& linear, float white) {
  WriteExr(path, linear);
  fs::path png = path;
  png.replace_extension(".png");
  WritePreviewPng(png, linear, white);
}

}  // namespace shadowsg
