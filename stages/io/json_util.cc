#include "stages/io/json_util.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "calib/error.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {
namespace fs = std::filesystem;

Json ParseJson(const std::string& text, const std::string& name) {
  try {
    return Json::parse(text);
  } catch (const Json::exception& e) {  // parse errors, and numbers out of range (1e999)
    throw InputError(name, std::string("invalid JSON: ") + e.what());
  }
}

Json ReadJsonFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string(), "file not found");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  if (ss.str().empty()) throw InputError(path.string(), "file is empty");
  return ParseJson(ss.str(), path.string());
}

void WriteJsonFile(const fs::path& path, const Json& json) {
  WriteTextAtomically(path, json.dump(2) + "\n");
}

void JsonReader::Fail(const std::string& key, const std::string& problem) const {
  const std::string where = Path(key);
  throw InputError(file_, (where.empty() ? "" : where + ": ") + problem);
}

const Json& JsonReader::Get(const std::string& key) const {
  if (!node_.is_object()) Fail("", "expected an object");
  auto it = node_.find(key);
  if (it == node_.end()) Fail(key, "missing key");
  return *it;
}

bool JsonReader::Has(const std::string& key) const {
  return node_.is_object() && node_.contains(key) && !node_.at(key).is_null();
}

JsonReader JsonReader::Child(const std::string& key) const {
  const Json& j = Get(key);
  if (!j.is_object() && !j.is_array()) Fail(key, "expected an object or array");
  return JsonReader(j, file_, Path(key));
}

JsonReader JsonReader::Element(size_t i) const {
  if (!node_.is_array() || i >= node_.size()) Fail("", "no element " + std::to_string(i));
  return JsonReader(node_[i], file_, key_ + "[" + std::to_string(i) + "]");
}

size_t JsonReader::Size() const {
  if (!node_.is_array()) Fail("", "expected an array");
  return node_.size();
}

double JsonReader::Number(const std::string& key) const {
  const Json& j = Get(key);
  if (!j.is_number()) Fail(key, "expected a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) Fail(key, "number is not finite");
  return v;
}

double JsonReader::Number(const std::string& key, double fallback) const {
  return Has(key) ? Number(key) : fallback;
}

int JsonReader::Int(const std::string& key) const {
  const Json& j = Get(key);
  if (!j.is_number_integer()) {
    if (j.is_number() && std::floor(j.get<double>()) == j.get<double>() && std::abs(j.get<double>()) < 2e9)
      return static_cast<int>(j.get<double>());
    Fail(key, "expected an integer");
  }
  const long long v = j.get<long long>();
  if (v < -2000000000LL || v > 2000000000LL) Fail(key, "integer out of range");
  return static_cast<int>(v);
}

int JsonReader::Int(const std::string& key, int fallback) const { return Has(key) ? Int(key) : fallback; }

bool JsonReader::Bool(const std::string& key, bool fallback) const {
  if (!Has(key)) return fallback;
  const Json& j = Get(key);
  if (!j.is_boolean()) Fail(key, "expected true or false");
  return j.get<bool>();
}

std::string JsonReader::String(const std::string& key) const {
  const Json& j = Get(key);
  if (!j.is_string()) Fail(key, "expected a string");
  return j.get<std::string>();
}

std::string JsonReader::String(const std::string& key, const std::string& fallback) const {
  return Has(key) ? String(key) : fallback;
}

Eigen::MatrixXd JsonReader::Matrix(const std::string& key, int rows, int cols) const {
  const Json& j = Get(key);
  const std::string shape = std::to_string(rows) + "x" + std::to_string(cols);
  Eigen::MatrixXd m(rows, cols);
  if (rows == 1) {
    if (!j.is_array() || static_cast<int>(j.size()) != cols)
      Fail(key, "expected an array of " + std::to_string(cols) + " numbers");
    for (int c = 0; c < cols; ++c) {
      if (!j[c].is_number()) Fail(key, "expected an array of " + std::to_string(cols) + " numbers");
      m(0, c) = j[c].get<double>();
    }
  } else {
    if (!j.is_array() || static_cast<int>(j.size()) != rows) Fail(key, "expected a " + shape + " array of numbers");
    for (int r = 0; r < rows; ++r) {
      if (!j[r].is_array() || static_cast<int>(j[r].size()) != cols)
        Fail(key, "expected a " + shape + " array of numbers");
      for (int c = 0; c < cols; ++c) {
        if (!j[r][c].is_number()) Fail(key, "expected a " + shape + " array of numbers");
        m(r, c) = j[r][c].get<double>();
      }
    }
  }
  if (!m.allFinite()) Fail(key, "contains a non-finite number");
  return m;
}

Eigen::Vector3d JsonReader::Vec3(const std::string& key) const { return Matrix(key, 1, 3).transpose(); }
Eigen::Matrix4d JsonReader::Mat4(const std::string& key) const { return Matrix(key, 4, 4); }

Json ToJson(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json ToJson(const Eigen::Matrix4d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 4; ++r) rows.push_back(Json::array({m(r, 0), m(r, 1), m(r, 2), m(r, 3)}));
  return rows;
}

}  // namespace shadowsg
