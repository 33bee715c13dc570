// Typed access to JSON documents with errors that name the file and the key
// path ("scene.json: camera.c2w: expected a 4x4 array of numbers").
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace shadowsg {

using Json = nlohmann::json;

// Parses a whole file; InputError on a missing file or a syntax error.
Json ReadJsonFile(const std::filesystem::path& path);
Json ParseJson(const std::string& text, const std::string& name_for_errors);
void WriteJsonFile(const std::filesystem::path& path, const Json& json);

// A cursor into a document that knows where it is, for error messages.
class JsonReader {
 public:
  JsonReader(const Json& node, std::string file, std::string key = "")
      : node_(node), file_(std::move(file)), key_(std::move(key)) {}

  bool Has(const std::string& key) const;
  JsonReader Child(const std::string& key) const;         // required object member
  JsonReader Element(size_t i) const;                      // array element
  size_t Size() const;                                     // array size (throws if not an array)
  double Number(const std::string& key) const;             // required finite number
  double Number(const std::string& key, double fallback) const;
  int Int(const std::string& key) const;
  int Int(const std::string& key, int fallback) const;
  bool Bool(const std::string& key, bool fallback) const;
  std::string String(const std::string& key) const;
  std::string String(const std::string& key, const std::string& fallback) const;
  Eigen::Vector3d Vec3(const std::string& key) const;
  Eigen::Matrix4d Mat4(const std::string& key) const;
  Eigen::MatrixXd Matrix(const std::string& key, int rows, int cols) const;

  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const;
  const Json& node() const { return node_; }
  const std::string& file() const { return file_; }
  std::string Path(const std::string& key) const {
    return key_.empty() ? key : key.empty() ? key_ : key_ + "." + key;
  }

 private:
  const Json& Get(const std::string& key) const;
  const Json& node_;
  std::string file_;
  std::string key_;
};

Json ToJson(const Eigen::Vector3d& v);
Json ToJson(const Eigen::Matrix4d& m);

}  // namespace shadowsg
