// shadowsg linearize: a DNG written here round-trips to known linear values;
// an exposure stack synthesised from an HDR image through a known camera
// curve is recovered; EXIF exposure times; undistortion.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "calib/error.h"
#include "calib/exif.h"
#include "calib/hdr_merge.h"
#include "calib/image_warp.h"
#include "calib/raw_decode.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/linearize_stage.h"
#include "synthetic_capture.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// ---- A minimal DNG writer (TIFF 6 + DNG 1.4 tags, uncompressed CFA) -------

class TiffBuilder {
 public:
  // Entries must be added in ascending tag order.
  void Short(uint16_t tag, std::vector<uint16_t> v) {
    std::string d;
    for (uint16_t x : v) Put16(&d, x);
    Add(tag, 3, static_cast<uint32_t>(v.size()), d);
  }
  void Long(uint16_t tag, std::vector<uint32_t> v) {
    std::string d;
    for (uint32_t x : v) Put32(&d, x);
    Add(tag, 4, static_cast<uint32_t>(v.size()), d);
  }
  void Byte(uint16_t tag, std::vector<uint8_t> v) {
    Add(tag, 1, static_cast<uint32_t>(v.size()), std::string(v.begin(), v.end()));
  }
  void Ascii(uint16_t tag, const std::string& s) { Add(tag, 2, static_cast<uint32_t>(s.size() + 1), s + '\0'); }
  void Rational(uint16_t tag, std::vector<double> v, bool is_signed) {
    std::string d;
    for (double x : v) {
      const int32_t num = static_cast<int32_t>(std::lround(x * 10000));
      Put32(&d, static_cast<uint32_t>(num));
      Put32(&d, 10000);
    }
    Add(tag, is_signed ? 10 : 5, static_cast<uint32_t>(v.size()), d);
  }
  // Lays out header, IFD, out-of-line values and the strip; `strip_offset_tag`
  // must have been added as a LONG placeholder.
  std::string Build(const std::string& strip) const {
    const uint32_t ifd_size = 2 + 12 * static_cast<uint32_t>(entries_.size()) + 4;
    uint32_t data_at = 8 + ifd_size;
    std::string ifd, data;
    Put16(&ifd, static_cast<uint16_t>(entries_.size()));
    std::vector<std::string> values;
    for (const auto& e : entries_) values.push_back(e.value);
    uint32_t strip_at = data_at;
    for (const auto& v : values)
      if (v.size() > 4) strip_at += static_cast<uint32_t>(v.size() + (v.size() & 1));
    for (const auto& e : entries_) {
      Put16(&ifd, e.tag);
      Put16(&ifd, e.type);
      Put32(&ifd, e.count);
      std::string v = e.tag == 273 ? Le32(strip_at) : e.value;
      if (v.size() <= 4) {
        v.resize(4, '\0');
        ifd += v;
      } else {
        Put32(&ifd, data_at + static_cast<uint32_t>(data.size()));
        data += v;
        if (v.size() & 1) data += '\0';
      }
    }
    Put32(&ifd, 0);
    std::string out = "II*";
    out += '\0';
    Put32(&out, 8);
    return out + ifd + data + strip;
  }

 private:
  struct Entry {
    uint16_t tag, type;
    uint32_t count;
    std::string value;
  };
  void Add(uint16_t tag, uint16_t type, uint32_t count, const std::string& value) {
    entries_.push_back({tag, type, count, value});
  }
  static void Put16(std::string* s, uint16_t v) {
    s->push_back(static_cast<char>(v & 0xff));
    s->push_back(static_cast<char>(v >> 8));
  }
  static void Put32(std::string* s, uint32_t v) {
    for (int i = 0; i < 4; ++i) s->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
  }
  static std::string Le32(uint32_t v) {
    std::string s;
    Put32(&s, v);
    return s;
  }
  std::vector<Entry> entries_;
};

constexpr int kW = 64, kH = 48;
constexpr int kBlack = 512, kWhite = 15000;

// Raw fractions of the white level (above black) per quadrant and channel.
const Eigen::Vector3d kPatch[4] = {{0.10, 0.20, 0.30}, {0.50, 0.40, 0.25}, {0.05, 0.60, 0.90}, {1.00, 0.70, 0.40}};

int Quadrant(int x, int y) { return (x >= kW / 2) + 2 * (y >= kH / 2); }

// dcraw's sRGB (D65) to XYZ matrix.
Eigen::Matrix3d XyzFromSrgb() {
  Eigen::Matrix3d m;
  m << 0.412453, 0.357580, 0.180423, 0.212671, 0.715160, 0.072169, 0.019334, 0.119193, 0.950227;
  return m;
}

// The camera's RGB in terms of linear sRGB (rows sum to 1: white stays white).
Eigen::Matrix3d CameraFromSrgb() {
  Eigen::Matrix3d m;
  m << 0.80, 0.15, 0.05, 0.10, 0.80, 0.10, 0.05, 0.15, 0.80;
  return m;
}

void WriteDng(const fs::path& path, double exposure_s, double scale = 1.0) {
  std::string strip;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const int c = (y % 2 == 0) ? (x % 2 == 0 ? 0 : 1) : (x % 2 == 0 ? 1 : 2);  // RGGB
      const double f = std::min(1.0, kPatch[Quadrant(x, y)][c] * scale);
      const auto v = static_cast<uint16_t>(std::lround(kBlack + f * (kWhite - kBlack)));
      strip.push_back(static_cast<char>(v & 0xff));
      strip.push_back(static_cast<char>(v >> 8));
    }
  const Eigen::Matrix3d cam_xyz = CameraFromSrgb() * XyzFromSrgb().inverse();  // XYZ -> camera
  TiffBuilder t;
  t.Long(254, {0});
  t.Long(256, {kW});
  t.Long(257, {kH});
  t.Short(258, {16});
  t.Short(259, {1});
  t.Short(262, {32803});
  t.Ascii(271, "shadowsg");
  t.Ascii(272, "synthetic");
  t.Long(273, {0});
  t.Short(274, {1});
  t.Short(277, {1});
  t.Long(278, {kH});
  t.Long(279, {static_cast<uint32_t>(strip.size())});
  t.Short(284, {1});
  t.Short(33421, {2, 2});
  t.Byte(33422, {0, 1, 1, 2});
  t.Rational(33434, {exposure_s}, false);
  t.Byte(50706, {1, 4, 0, 0});
  t.Byte(50707, {1, 1, 0, 0});
  t.Ascii(50708, "shadowsg synthetic");
  t.Short(50713, {1, 1});
  t.Long(50714, {kBlack});
  t.Long(50717, {kWhite});
  t.Rational(50721,
             {cam_xyz(0, 0), cam_xyz(0, 1), cam_xyz(0, 2), cam_xyz(1, 0), cam_xyz(1, 1), cam_xyz(1, 2), cam_xyz(2, 0),
              cam_xyz(2, 1), cam_xyz(2, 2)},
             true);
  t.Rational(50728, {0.5, 1.0, 0.8}, false);  // as-shot neutral: WB multipliers 2, 1, 1.25
  t.Short(50778, {21});                       // D65
  std::ofstream(path, std::ios::binary) << t.Build(strip);
}

// Checks the interior of every quadrant (away from demosaicing borders).
template <typename F>
void ForInteriors(const Image& img, int margin, F&& f) {
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const int qx = x % (img.width / 2), qy = y % (img.height / 2);
      if (qx < margin || qy < margin || qx >= img.width / 2 - margin || qy >= img.height / 2 - margin) continue;
      f(x, y, (x >= img.width / 2) + 2 * (y >= img.height / 2));
    }
}

TEST(Raw, DngRoundTripsToKnownLinearValues) {
  TempDir tmp;
  WriteDng(tmp / "test.dng", 1.0 / 125);
  RawDecodeOptions o;
  o.colour = RawColourSpace::kCamera;
  o.white_balance = WhiteBalanceMode::kNone;
  const RawImage raw = DecodeRaw(tmp / "test.dng", o);
  ASSERT_EQ(raw.rgb.width, kW);
  ASSERT_EQ(raw.rgb.height, kH);
  EXPECT_EQ(raw.make, "shadowsg");
  EXPECT_NEAR(raw.black_level, kBlack, 1e-9);
  EXPECT_NEAR(raw.white_level, kWhite, 1e-9);
  EXPECT_NEAR(raw.exposure_time_s, 1.0 / 125, 1e-6);
  EXPECT_TRUE(raw.has_colour_matrix);
  double worst = 0;
  ForInteriors(raw.rgb, 5, [&](int x, int y, int q) {
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(raw.rgb.at(x, y, c) - kPatch[q][c]));
    EXPECT_EQ(raw.clipped.at(x, y, 0), q == 3 ? 1.0f : 0.0f) << x << "," << y;
  });
  std::printf("DNG round trip (camera RGB, no WB): worst error %.2e\n", worst);
  EXPECT_LT(worst, 2e-4);  // 16-bit steps of LibRaw's output

  // As-shot white balance: 1 / AsShotNeutral = (2, 1, 1.25), not clipped at 1.
  o.white_balance = WhiteBalanceMode::kAsShot;
  const RawImage wb = DecodeRaw(tmp / "test.dng", o);
  EXPECT_NEAR(wb.wb_multipliers[0], 2.0, 1e-3);
  EXPECT_NEAR(wb.wb_multipliers[2], 1.25, 1e-3);
  worst = 0;
  ForInteriors(wb.rgb, 5, [&](int x, int y, int q) {
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, std::abs(wb.rgb.at(x, y, c) - kPatch[q][c] * wb.wb_multipliers[c]));
  });
  EXPECT_LT(worst, 5e-4);
  EXPECT_GT(wb.rgb.at(kW / 4, kH / 4 * 3, 0), 0.0f);

  // Linear sRGB: the inverse of the camera matrix written in ColorMatrix1.
  o.colour = RawColourSpace::kSrgb;
  const RawImage srgb = DecodeRaw(tmp / "test.dng", o);
  const Eigen::Matrix3d srgb_from_cam = CameraFromSrgb().inverse();
  worst = 0;
  ForInteriors(srgb.rgb, 5, [&](int x, int y, int q) {
    const Eigen::Vector3d expect = srgb_from_cam * Eigen::Vector3d(kPatch[q].cwiseProduct(wb.wb_multipliers));
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(srgb.rgb.at(x, y, c) - expect[c]));
  });
  std::printf("DNG round trip (linear sRGB, as-shot WB): worst error %.2e\n", worst);
  EXPECT_LT(worst, 3e-3);

  // Half size: 2x2 binning, the same values.
  o.half_size = true;
  o.colour = RawColourSpace::kCamera;
  o.white_balance = WhiteBalanceMode::kNone;
  const RawImage half = DecodeRaw(tmp / "test.dng", o);
  ASSERT_EQ(half.rgb.width, kW / 2);
  ForInteriors(half.rgb, 2, [&](int x, int y, int q) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(half.rgb.at(x, y, c), kPatch[q][c], 2e-4);
  });
}

TEST(Raw, NotARawIsOneClearError) {
  TempDir tmp;
  std::ofstream(tmp / "junk.nef") << "not a raw file at all";
  try {
    DecodeRaw(tmp / "junk.nef", RawDecodeOptions());
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("junk.nef"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

// ---- Exposure stacks -----------------------------------------------------

// The scene: log-uniform radiance from 1e-3 to 10 along x, tinted along y.
Image HdrScene(int w, int h) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double e = std::pow(10.0, -3.0 + 4.0 * (x + 0.5) / w);
      const double t = static_cast<double>(y) / (h - 1);
      img.set_rgb(img.index(x, y), Eigen::Vector3f(e * (0.6 + 0.4 * t), e, e * (1.0 - 0.4 * t)));
    }
  return img;
}

// The known camera curve: a gamma with a soft shoulder, 8-bit.
double CameraCurve(double x) { return std::pow(x / (1.0 + 0.25 * x), 1.0 / 2.2) * std::pow(1.25, 1.0 / 2.2); }

Image Expose(const Image& radiance, double t) {
  Image ldr(radiance.width, radiance.height, 3);
  for (size_t i = 0; i < ldr.data.size(); ++i)
    ldr.data[i] = static_cast<float>(std::round(std::clamp(CameraCurve(radiance.data[i] * t), 0.0, 1.0) * 255) / 255);
  return ldr;
}

const std::vector<double> kTimes = {1.0 / 8, 1.0 / 64, 1.0, 1.0 / 512, 8.0};

void CheckRecovered(const HdrResult& r, const Image& truth, const char* label) {
  // Radiance is recovered up to one global scale.
  std::vector<double> ratio, err;
  for (size_t i = 0; i < truth.data.size(); ++i) ratio.push_back(truth.data[i] / r.radiance.data[i]);
  std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
  const double s = ratio[ratio.size() / 2];
  for (size_t i = 0; i < truth.data.size(); ++i)
    err.push_back(std::abs(s * r.radiance.data[i] - truth.data[i]) / truth.data[i]);
  std::sort(err.begin(), err.end());
  const double median = err[err.size() / 2], p95 = err[err.size() * 95 / 100];
  std::printf("%s: relative radiance error median %.2f %%, 95th percentile %.2f %%\n", label, 100 * median, 100 * p95);
  EXPECT_LT(median, 0.03) << label;
  EXPECT_LT(p95, 0.08) << label;
}

TEST(Hdr, DebevecRecoversStackOfKnownCurve) {
  const Image truth = HdrScene(160, 40);
  std::vector<Image> stack;
  for (double t : kTimes) stack.push_back(Expose(truth, t));
  LdrStackOptions o;
  const HdrResult r = MergeLdrStack(stack, kTimes, o);
  CheckRecovered(r, truth, "Debevec");
  // The response's shape: exposure ratios between codes follow the curve.
  const auto inverse = [](int z) {
    // x / (1 + 0.25 x) = (z / 255)^2.2 / 1.25  ->  x = y / (1 - 0.25 y)
    const double y = std::pow(z / 255.0, 2.2) / 1.25;
    return y / (1 - 0.25 * y);
  };
  for (int z : {32, 64, 200})
    EXPECT_NEAR(r.response[1][z] / r.response[1][128], inverse(z) / inverse(128), 0.08 * inverse(z) / inverse(128))
        << "code " << z;
  EXPECT_EQ(r.clipped.at(159, 0, 0), 0.0f);
}

TEST(Hdr, RobertsonRecoversDenseStackOfKnownCurve) {
  // Robertson's iteration starts from a linear response and needs overlapping
  // exposures: on brackets 3 stops apart (kTimes) OpenCV's implementation
  // stays 20 % off; 1 stop apart it is exact to 1 %.
  const Image truth = HdrScene(160, 40);
  std::vector<Image> stack;
  std::vector<double> times;
  for (int k = -9; k <= 3; ++k) {
    times.push_back(std::ldexp(1.0, k));
    stack.push_back(Expose(truth, times.back()));
  }
  LdrStackOptions o;
  o.method = ResponseMethod::kRobertson;
  CheckRecovered(MergeLdrStack(stack, times, o), truth, "Robertson");
}

TEST(Hdr, LinearStackMergesAroundClipping) {
  // Two linear exposures, 4x apart; the longer clips above 1.
  Image a(8, 1, 3), b(8, 1, 3), ma(8, 1, 1), mb(8, 1, 1);
  for (int x = 0; x < 8; ++x) {
    const float e = 0.05f * (1 << x);  // 0.05 .. 6.4 in the short exposure's units
    a.set_rgb(x, Eigen::Vector3f::Constant(std::min(e, 1.0f)));
    b.set_rgb(x, Eigen::Vector3f::Constant(std::min(4 * e, 1.0f)));
    ma.data[x] = e >= 1.0f;
    mb.data[x] = 4 * e >= 1.0f;
  }
  const HdrResult r = MergeLinearStack({a, b}, {ma, mb}, {1.0, 4.0}, false);
  for (int x = 0; x < 8; ++x) {
    const float e = 0.05f * (1 << x);
    if (e < 1.0f) {
      EXPECT_NEAR(r.radiance.at(x, 0, 1), e, 1e-6) << x;
    }
    EXPECT_EQ(r.clipped.data[x], e >= 1.0f ? kMaskSaturated : 0.0f) << x;
  }
}

TEST(Hdr, InverseSrgbOfSingleImage) {
  Image ldr(3, 1, 3);
  ldr.set_rgb(0, Eigen::Vector3f::Constant(128 / 255.0f));
  ldr.set_rgb(1, Eigen::Vector3f::Constant(1.0f));
  ldr.set_rgb(2, Eigen::Vector3f::Zero());
  const HdrResult r = LinearizeSrgb(ldr);
  EXPECT_NEAR(r.radiance.at(0, 0, 0), 0.2158605, 1e-5);
  EXPECT_EQ(r.clipped.data[0], 0.0f);
  EXPECT_EQ(r.clipped.data[1], kMaskSaturated);
  EXPECT_EQ(r.clipped.data[2], kMaskUnderexposed);
}

// ---- EXIF ---------------------------------------------------------------

// A JPEG with an APP1 EXIF segment giving ExposureTime = 1/250 s.
void WriteJpegWithExposure(const fs::path& path, const Image& img) {
  WriteLdr(path, img);
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string jpeg = ss.str();
  const unsigned char tiff[] = {'I', 'I', 42, 0, 8, 0, 0, 0,
                                // IFD0: one entry, ExifIFD pointer -> 26
                                1, 0, 0x69, 0x87, 4, 0, 1, 0, 0, 0, 26, 0, 0, 0, 0, 0, 0, 0,
                                // Exif IFD: ExposureTime RATIONAL at 44
                                1, 0, 0x9A, 0x82, 5, 0, 1, 0, 0, 0, 44, 0, 0, 0, 0, 0, 0, 0,
                                // 1 / 250
                                1, 0, 0, 0, 250, 0, 0, 0};
  std::string app1 = "Exif";
  app1 += std::string(2, '\0');
  app1.append(reinterpret_cast<const char*>(tiff), sizeof tiff);
  const size_t len = app1.size() + 2;
  std::string seg = {static_cast<char>(0xFF), static_cast<char>(0xE1), static_cast<char>(len >> 8),
                     static_cast<char>(len & 0xff)};
  jpeg.insert(2, seg + app1);
  std::ofstream(path, std::ios::binary) << jpeg;
}

TEST(Exif, ReadsExposureTimeOfJpeg) {
  TempDir tmp;
  WriteJpegWithExposure(tmp / "a.jpg", Image(16, 8, 3, 0.5f));
  const ExifInfo info = ReadExif(tmp / "a.jpg");
  ASSERT_TRUE(info.exposure_time_s.has_value());
  EXPECT_DOUBLE_EQ(*info.exposure_time_s, 1.0 / 250);
  EXPECT_EQ(ReadLdr(tmp / "a.jpg").width, 16);  // still a valid JPEG
  WriteLdr(tmp / "b.png", Image(4, 4, 3, 0.5f));
  EXPECT_FALSE(ReadExif(tmp / "b.png").exposure_time_s.has_value());
  EXPECT_FALSE(ParseExifTiff("II*\0garbage").exposure_time_s.has_value());
}

// ---- Undistortion ----------------------------------------------------------

TEST(Undistort, MatchesThePinholeView) {
  Camera cam;
  cam.width = 320;
  cam.height = 240;
  cam.fx = cam.fy = 300;
  cam.cx = 160;
  cam.cy = 118;
  cam.k1 = -0.3;
  cam.k2 = 0.1;
  cam.p1 = 0.002;
  const Eigen::Matrix4d pose = testing::Pose({1, 0.3, 0}, 20, {-0.1, -0.06, 0.5});
  const auto board = testing::CheckerboardTexture(8, 5, 0.03);
  const Image distorted = testing::PlaneRenderer(cam).Render(pose, board);
  const Image pinhole = testing::PlaneRenderer(PinholeOf(cam)).Render(pose, board);
  Image outside;
  const Image undistorted = UndistortImage(distorted, cam, WarpSampling::kBilinear, &outside);
  double sum = 0;
  int n = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x)
      if (outside.at(x, y, 0) == 0) {
        sum += std::abs(undistorted.at(x, y, 0) - pinhole.at(x, y, 0));
        ++n;
      }
  EXPECT_GT(n, cam.width * cam.height / 2);
  EXPECT_LT(sum / n, 0.01);  // bilinear resampling of sharp edges
  const Camera half = ResizeCamera(cam, 160, 120);
  EXPECT_DOUBLE_EQ(half.fx, 150);
  EXPECT_DOUBLE_EQ(half.cx, (160 + 0.5) / 2 - 0.5);
}

// ---- The stage ---------------------------------------------------------------

TEST(LinearizeStage, RawStackAndUndistortion) {
  TempDir tmp;
  WriteDng(tmp / "long.dng", 1.0 / 30, 2.0);  // 2x the light: quadrant 3 clips in R, G
  WriteDng(tmp / "short.dng", 1.0 / 60, 1.0);
  CameraFile cf;
  cf.camera.width = kW;
  cf.camera.height = kH;
  cf.camera.fx = cf.camera.fy = 80;
  cf.camera.cx = 31.5;
  cf.camera.cy = 23.5;
  cf.camera.k1 = -0.05;
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));

  LinearizeStageOptions o;
  o.inputs = {tmp / "short.dng", tmp / "long.dng"};
  o.out = tmp / "out" / "photo.exr";
  o.raw.colour = RawColourSpace::kCamera;
  o.raw.white_balance = WhiteBalanceMode::kNone;
  const LinearizeStageResult r = RunLinearizeStage(o, StageContext());
  EXPECT_EQ(r.kind, "raw stack");
  const Image merged = ReadExr(r.exr);
  const Image mask = ReadMask(r.mask);
  // Interior of quadrant 0: both exposures valid; reads as the first (short).
  EXPECT_NEAR(merged.at(8, 8, 1), kPatch[0][1], 1e-3);
  // Quadrant 3 R clips in both exposures.
  EXPECT_EQ(mask.at(kW * 3 / 4, kH * 3 / 4, 0), 1.0f);
  EXPECT_EQ(mask.at(8, 8, 0), 0.0f);
  EXPECT_TRUE(fs::exists(r.preview));
  const Json report = ReadJsonFile(r.report);
  EXPECT_EQ(report["exposure_times_s"].size(), 2u);
  EXPECT_NEAR(report["raw"][0]["white_level"].get<double>(), kWhite, 1e-9);

  o.undistort = tmp / "camera.json";
  o.out = tmp / "out" / "undistorted.exr";
  const LinearizeStageResult u = RunLinearizeStage(o, StageContext());
  const CameraFile pin = ReadCameraFile(u.camera_json);
  EXPECT_EQ(pin.camera.k1, 0.0);
  EXPECT_EQ(pin.camera.fx, 80.0);
  const Image umask = ReadImage(u.mask);
  EXPECT_EQ(ReadExr(u.exr).width, kW);
  EXPECT_EQ(umask.width, kW);
}

TEST(LinearizeStage, EightBitStackWithTimes) {
  TempDir tmp;
  const Image truth = HdrScene(160, 40);
  LinearizeStageOptions o;
  for (size_t i = 0; i < kTimes.size(); ++i) {
    const fs::path p = tmp / ("bracket" + std::to_string(i) + ".png");
    WriteLdr(p, Expose(truth, kTimes[i]));
    o.inputs.push_back(p);
  }
  o.out = tmp / "hdr.exr";
  o.times = kTimes;
  const LinearizeStageResult r = RunLinearizeStage(o, StageContext());
  EXPECT_EQ(r.kind, "8-bit stack");
  EXPECT_TRUE(fs::exists(r.response_png));
  EXPECT_TRUE(fs::exists(tmp / "hdr_response.csv"));
  // Without times, PNGs carry no EXIF: one clear error naming the file.
  o.times.clear();
  try {
    RunLinearizeStage(o, StageContext());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bracket0.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--times"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shadowsg
