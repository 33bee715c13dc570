// The registered scene in memory (scene-format.md): camera, shadow plane,
// casters and virtual objects, and the observation. No file names beyond
// those kept for reporting; loading lives in stages/io.
#pragma once

#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "calib/image.h"
#include "solver/mesh.h"
#include "solver/sphere_tree.h"

namespace shadowsg {

struct Plane {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, towards camera and lights
  Eigen::Vector3d scale = Eigen::Vector3d(1, 1, 1);   // half extents in the plane frame
  Eigen::Vector3d diffuse = Eigen::Vector3d::Constant(0.8);  // Lambertian albedo
  // Optional albedo texture (linear RGB, multiplies `diffuse`), stretched over
  // the rectangle: column 0 at local x = -scale[0], row 0 at local y = +scale[1]
  // (the image reads as the plane seen from above its normal). texture_path is
  // the file as written in scene.json ("plane": {"texture": ...}).
  std::optional<Image> albedo_texture;
  std::string texture_path;
};

// True when p (on the plane) lies inside the plane's rectangle.
bool PlaneRectContains(const Plane& plane, const Eigen::Vector3d& p);
// Albedo at plane point p: diffuse, times the texture (bilinear, clamped at
// the rectangle's border) when there is one.
Eigen::Vector3d PlaneAlbedo(const Plane& plane, const Eigen::Vector3d& p);
// Ray parameter of the hit with the infinite plane (nullopt if parallel or behind).
std::optional<double> IntersectPlane(const Plane& plane, const Eigen::Vector3d& origin,
                                     const Eigen::Vector3d& dir);

struct SceneObject {
  std::string mesh_path;  // as written in scene.json, for messages and writing back
  std::string sph_path;
  TriangleMesh mesh;      // object coordinates
  Eigen::Matrix4d o2w = Eigen::Matrix4d::Identity();
  Eigen::Vector3d diffuse = Eigen::Vector3d::Constant(0.8);
  bool is_train = true;
  std::optional<SphereTree> sphere_tree;  // object coordinates

  TriangleMesh WorldMesh() const { return TransformMesh(mesh, o2w); }
};

struct Scene {
  std::string name;
  Camera camera;
  Plane plane;
  std::vector<SceneObject> objects;
  Image image;                             // linear RGB observation
  std::optional<Image> mask;               // 1 channel, non-zero = usable
  std::optional<Image> env_gt;             // evaluation only
  std::optional<Image> image_virtual_objs; // evaluation only

  std::vector<const SceneObject*> Casters() const;        // is_train objects
  std::vector<const SceneObject*> VirtualObjects() const; // !is_train objects
};

}  // namespace shadowsg
