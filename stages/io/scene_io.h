// Registered-scene folders (scene-format.md): scene.json, image, meshes,
// optional sphere trees, mask, ground-truth env map and insertion image.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "solver/scene.h"
#include "stages/io/json_util.h"

namespace shadowsg {

struct SceneLoadOptions {
  bool require_image = true;  // false for tools that only render the scene's geometry
  bool load_extras = true;    // mask, env_gt, image_virtual_objs
  // The image must be something to solve from (CheckObservation: not black,
  // not one value everywhere); otherwise only finite.
  bool require_observation = false;
};

Scene LoadScene(const std::filesystem::path& dir, const SceneLoadOptions& options = {});

// One entry of scene.json's "objects" (path_to_mesh, path_to_sph, o2w,
// diffuse, is_train), its files relative to `dir`; the mesh is read, and the
// sphere tree when the file exists.
SceneObject ParseSceneObject(const JsonReader& object, const std::filesystem::path& dir);
// An objects file: virtual objects to insert (`shadowsg composite --objects`),
//   {"format": "objects/1", "objects": [ entries as in scene.json ]}
// with files relative to the objects file; "is_train" must be absent or false.
std::vector<SceneObject> ReadObjectsFile(const std::filesystem::path& path);

// The parts of scene.json that do not need other files (camera, plane,
// object poses and paths); `file` names the document in errors.
Camera ParseCamera(const JsonReader& camera);
Plane ParsePlane(const JsonReader& plane);  // texture_path only; LoadScene reads the texture
// The observation must be able to show a shadow: finite, not black, not one
// value everywhere (a saturated or blank frame). InputError names `path`.
void CheckObservation(const Image& image, const std::filesystem::path& path);
// A plane albedo texture: EXR as linear, PNG/JPEG as sRGB-encoded (decoded to linear).
Image ReadPlaneTexture(const std::filesystem::path& path);

Json CameraToJson(const Camera& camera);
Json PlaneToJson(const Plane& plane);
// scene.json for a scene whose meshes are at the objects' mesh_path.
Json SceneToJson(const Scene& scene);

}  // namespace shadowsg
