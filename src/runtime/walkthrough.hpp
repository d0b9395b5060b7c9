// The walk-through scene of Liang et al., "Automatic Mesh and Shader Level of Detail", §7.2.2:
// ~400 objects on a ground plane, a camera walking through them, and each object's level chosen
// every frame by the runtime selector (runtime.hpp) from its distance. Used by bench/walkthrough
// and its test; private to duolod (not an installed header).
//
// Data flows one way: a `duolod generate` folder is read (io, runtime.hpp) into a LodFolder, the
// folders of one configuration are uploaded (render), and a WalkScene (pure geometry, no GPU) says
// where the instances and the camera are. selectFrame() turns one camera pose into instance
// batches for Renderer::renderScene().
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "duolod/runtime.hpp"

namespace duolod::runtime {

// One `duolod generate` output folder: lod.json, the level meshes of lod.gltf and the level
// shaders (SPIR-V, what the generator rendered).
struct LodFolder {
  std::string directory;
  Policy policy;
  std::vector<core::Mesh> meshes;             // per level
  std::vector<render::SpirvBinary> shaders;   // per level
  core::Sphere bounds;                        // the original asset's bounding sphere (lod.json)
  render::Display display;                    // the display the LOD was made for
  metric::BoundConfig bound;                  // eq. (4), in asset units
  std::string asset_source, optimizer;
  // lod.json files from before shader parameters were exported have none listed: a level that
  // moved values to parameters then draws them as 0 (same cost, wrong colours).
  bool lists_parameters = false;
  // Total generation time from DIRECTORY.log (the `duolod generate` output: "time ... total N s"),
  // or -1 when there is no log.
  double generation_seconds = -1;
};
core::Result<LodFolder> loadLodFolder(const std::string& directory);

// ---------------------------------------------------------------------------------------------
// The scene: instances of one or several kinds of object on a square field, and the camera path.

struct WalkSceneOptions {
  int objects = 400;
  uint64_t seed = 1;
  float spacing = 5.0f;     // grid step between neighbours, in object radii (objects are scaled
                            // to radius 1)
  float jitter = 0.15f;     // random offset from the grid point, in grid steps
  int frames = 60;          // camera poses along the path
  float eye_height = 1.2f;  // in object radii above the ground
  // Each grid point holds one model made of every kind, as parts around the point (a ring of
  // `part_ring` object radii, turned with the model), instead of one object of a random kind: the
  // paper's Table 4 (§7.2.2, the Trooper: a model whose sub-meshes each have their own LOD,
  // rendered together). Every part still picks its own level by its own distance.
  bool compound = false;
  float part_ring = 1.25f;
};

struct WalkInstance {
  int kind = 0;        // which object (index into the kinds given to buildWalkScene)
  core::Mat4 model;    // object -> world
  core::Vec3 center;   // bounding-sphere centre, world space
  float scale = 1;     // world units per asset unit
};

struct CameraPose {
  core::Vec3 eye, target;
};

struct WalkScene {
  std::vector<WalkInstance> instances;
  float half_extent = 0;  // the field is [−half_extent, half_extent]² on y = 0
  std::vector<CameraPose> path;
};

// Seeded: the same kinds, options and seed give the same scene. Each kind is scaled to radius 1,
// stands on the ground (its lowest point at y = 0) with a random turn about +y; kinds are drawn
// uniformly. The camera enters the field from outside along the corridor between the two middle
// columns and walks to the far side, swaying its view left and right.
WalkScene buildWalkScene(std::span<const core::Mesh* const> kinds,
                         const WalkSceneOptions& options);

// The ground: a square quad at y = 0 over the field, with normals and uv0.
core::Mesh groundMesh(float half_extent);

// ---------------------------------------------------------------------------------------------
// A configuration (no LOD, mesh-only, ...): per kind, its levels uploaded to a renderer.

struct KindLevels {
  std::vector<render::Renderer::AssetId> assets;      // per level
  std::vector<render::Renderer::ProgramId> programs;  // per level
  Policy policy;                                      // one level for "no LOD"
  // Converts a world-space distance to the equivalent distance in lod.json's units on the
  // display the LOD was made for (same footprint in pixels): d · (1/scale) · F_gen / F_disp with
  // F = height / (2·tan(fov/2)).
  double display_factor = 1;
  metric::BoundConfig bound;
};
struct Configuration {
  std::string name;
  std::vector<KindLevels> kinds;
};

// Uploads a folder's levels (level 0's asset carries the materials and textures of `materials`).
core::Result<KindLevels> uploadLevels(render::Renderer& renderer, const core::Asset& materials,
                                      const LodFolder& folder, const render::Display& display);
// "No LOD": the original asset with the original shader as a single level.
core::Result<KindLevels> uploadOriginal(render::Renderer& renderer, const core::Asset& asset,
                                        const render::GlslSource& shader,
                                        const LodFolder& reference, const render::Display& display);

// Per-instance level selection state of one configuration over a path.
class FrameSelector {
 public:
  FrameSelector(const Configuration& configuration, const WalkScene& scene,
                SelectorOptions options = {});
  struct Frame {
    std::vector<render::InstanceBatch> batches;  // by (level, kind), finest first, front to back
    std::vector<int> batch_levels;               // each batch's level
    std::vector<int> batch_kinds;                // and kind
    std::vector<int> level_histogram;            // visible instances per level
    int visible = 0;
  };
  // Chooses every visible instance's level for `pose` (sphere-frustum culled) and batches them.
  Frame select(const CameraPose& pose, const render::SceneCamera& camera);

 private:
  const Configuration& configuration_;
  const WalkScene& scene_;
  std::vector<LevelSelector> selectors_;  // per instance
};

// The camera for `pose` on a width × height display with vertical field of view fov_y_deg; the
// light sits above and behind the eye, as the paper's lights sit near the camera (§7).
render::SceneCamera sceneCamera(const CameraPose& pose, int width, int height, float fov_y_deg);

}  // namespace duolod::runtime
