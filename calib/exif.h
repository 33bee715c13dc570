// The few EXIF fields the capture stages need (exposure time of bracketed
// JPEGs), read from a JPEG's APP1 segment or a TIFF-structured file.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace shadowsg {

struct ExifInfo {
  std::optional<double> exposure_time_s;  // ExposureTime, else 2^-ShutterSpeedValue
  std::optional<double> f_number;
  std::optional<double> iso;
  std::string make, model;
};

// Parses the TIFF structure of an EXIF block ("II*\0" or "MM\0*" header).
// Malformed data yields the fields that could be read, never an error.
ExifInfo ParseExifTiff(const std::string& tiff);
// Reads a JPEG's EXIF (APP1 "Exif\0\0") or a TIFF file's tags; empty info when
// the file has none. InputError only when the file cannot be read.
ExifInfo ReadExif(const std::filesystem::path& path);

}  // namespace shadowsg
