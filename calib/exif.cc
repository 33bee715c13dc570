#include "calib/exif.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "calib/error.h"

namespace shadowsg {
namespace {

// TIFF tags (TIFF 6.0 and EXIF 2.3).
constexpr uint16_t kTagMake = 0x010F;
constexpr uint16_t kTagModel = 0x0110;
constexpr uint16_t kTagExifIfd = 0x8769;
constexpr uint16_t kTagExposureTime = 0x829A;
constexpr uint16_t kTagFNumber = 0x829D;
constexpr uint16_t kTagIso = 0x8827;
constexpr uint16_t kTagShutterSpeed = 0x9201;

// TIFF field types.
constexpr uint16_t kAscii = 2, kShort = 3, kLong = 4, kRational = 5, kSRational = 10;

class TiffReader {
 public:
  explicit TiffReader(const std::string& d) : d_(d) {}
  bool Header(uint32_t* ifd0) {
    if (d_.size() < 8) return false;
    if (d_[0] == 'I' && d_[1] == 'I')
      little_ = true;
    else if (d_[0] == 'M' && d_[1] == 'M')
      little_ = false;
    else
      return false;
    if (U16(2) != 42) return false;
    *ifd0 = U32(4);
    return true;
  }
  bool Ok(size_t off, size_t n) const { return off <= d_.size() && n <= d_.size() - off; }
  uint16_t U16(size_t off) const {
    if (!Ok(off, 2)) return 0;
    const auto b = [&](size_t i) { return static_cast<uint16_t>(static_cast<unsigned char>(d_[off + i])); };
    return little_ ? static_cast<uint16_t>(b(0) | b(1) << 8) : static_cast<uint16_t>(b(0) << 8 | b(1));
  }
  uint32_t U32(size_t off) const {
    if (!Ok(off, 4)) return 0;
    const auto b = [&](size_t i) { return static_cast<uint32_t>(static_cast<unsigned char>(d_[off + i])); };
    return little_ ? (b(0) | b(1) << 8 | b(2) << 16 | b(3) << 24) : (b(0) << 24 | b(1) << 16 | b(2) << 8 | b(3));
  }

  struct Entry {
    uint16_t tag, type;
    uint32_t count;
    size_t value_offset;  // where the value lives (inline or pointed to)
  };
  std::vector<Entry> Ifd(uint32_t off) const {
    std::vector<Entry> out;
    if (!Ok(off, 2)) return out;
    const uint16_t n = U16(off);
    for (uint16_t i = 0; i < n; ++i) {
      const size_t e = off + 2 + 12u * i;
      if (!Ok(e, 12)) break;
      Entry en{U16(e), U16(e + 2), U32(e + 4), e + 8};
      static const int kSize[] = {0, 1, 1, 2, 4, 8, 1, 1, 2, 4, 8, 4, 8};
      const size_t bytes = en.type < 13 ? static_cast<size_t>(kSize[en.type]) * en.count : 0;
      if (bytes > 4) en.value_offset = U32(e + 8);
      out.push_back(en);
    }
    return out;
  }
  std::optional<double> Number(const Entry& e) const {
    if (e.count < 1) return std::nullopt;
    switch (e.type) {
      case kShort:
        return U16(e.value_offset);
      case kLong:
        return U32(e.value_offset);
      case kRational: {
        const uint32_t den = U32(e.value_offset + 4);
        if (!Ok(e.value_offset, 8) || den == 0) return std::nullopt;
        return static_cast<double>(U32(e.value_offset)) / den;
      }
      case kSRational: {
        const auto num = static_cast<int32_t>(U32(e.value_offset));
        const auto den = static_cast<int32_t>(U32(e.value_offset + 4));
        if (!Ok(e.value_offset, 8) || den == 0) return std::nullopt;
        return static_cast<double>(num) / den;
      }
      default:
        return std::nullopt;
    }
  }
  std::string Ascii(const Entry& e) const {
    if (e.type != kAscii || !Ok(e.value_offset, e.count)) return "";
    std::string s = d_.substr(e.value_offset, e.count);
    while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
    return s;
  }

 private:
  const std::string& d_;
  bool little_ = true;
};

}  // namespace

ExifInfo ParseExifTiff(const std::string& tiff) {
  ExifInfo info;
  TiffReader r(tiff);
  uint32_t ifd0 = 0;
  if (!r.Header(&ifd0)) return info;
  std::optional<double> shutter_apex;
  std::set<uint32_t> seen;  // guards against IFD loops in malformed files
  std::vector<uint32_t> todo{ifd0};
  while (!todo.empty()) {
    const uint32_t off = todo.back();
    todo.pop_back();
    if (!seen.insert(off).second) continue;
    for (const auto& e : r.Ifd(off)) {
      switch (e.tag) {
        case kTagMake:
          info.make = r.Ascii(e);
          break;
        case kTagModel:
          info.model = r.Ascii(e);
          break;
        case kTagExifIfd:
          if (auto v = r.Number(e)) todo.push_back(static_cast<uint32_t>(*v));
          break;
        case kTagExposureTime:
          info.exposure_time_s = r.Number(e);
          break;
        case kTagFNumber:
          info.f_number = r.Number(e);
          break;
        case kTagIso:
          info.iso = r.Number(e);
          break;
        case kTagShutterSpeed:
          shutter_apex = r.Number(e);
          break;
        default:
          break;
      }
    }
  }
  if (info.exposure_time_s && !(*info.exposure_time_s > 0)) info.exposure_time_s.reset();
  if (!info.exposure_time_s && shutter_apex) info.exposure_time_s = std::pow(2.0, -*shutter_apex);
  return info;
}

ExifInfo ReadExif(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string d = ss.str();
  if (d.size() >= 4 && (d.compare(0, 4, "II*\0", 4) == 0 || d.compare(0, 4, "MM\0*", 4) == 0)) return ParseExifTiff(d);
  // JPEG: walk the marker segments up to the image data.
  if (d.size() < 4 || static_cast<unsigned char>(d[0]) != 0xFF || static_cast<unsigned char>(d[1]) != 0xD8) return {};
  size_t p = 2;
  while (p + 4 <= d.size()) {
    if (static_cast<unsigned char>(d[p]) != 0xFF) break;
    const unsigned marker = static_cast<unsigned char>(d[p + 1]);
    if (marker == 0xD9 || marker == 0xDA) break;  // end of image, start of scan
    const size_t len =
        static_cast<size_t>(static_cast<unsigned char>(d[p + 2])) << 8 | static_cast<unsigned char>(d[p + 3]);
    if (len < 2 || p + 2 + len > d.size()) break;
    if (marker == 0xE1 && len >= 8 && d.compare(p + 4, 6, "Exif\0\0", 6) == 0)
      return ParseExifTiff(d.substr(p + 10, len - 8));
    p += 2 + len;
  }
  return {};
}

}  // namespace shadowsg
