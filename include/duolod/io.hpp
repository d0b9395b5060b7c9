// duolod io: asset readers (glTF 2.0 .gltf/.glb, OBJ+MTL, PLY, OFF), writers (glTF, OBJ), PNG, and
// atomic file output. Readers never crash on bad input: they return an Error naming the file and
// the problem (line, field or byte offset where known).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::io {

struct LoadOptions {
  bool load_textures = true;      // decode texture images (missing image files are an error)
  // Applies when load_textures is true. Set to false, it reads each PNG or JPEG texture's bytes
  // and size without decoding it (Texture::encoded, Texture::image left empty), for assets whose
  // textures are only written back (`duolod simplify` without rendering: WaterBottle loads in
  // 0.011 s instead of 0.25 s). Such textures cannot be drawn (render::Renderer::uploadAsset
  // refuses them). Other formats are decoded all the same.
  bool decode_textures = true;
  bool generate_normals = true;   // when the file has none
  bool generate_tangents = true;  // when the file has none but has normals and uv0
  bool weld = true;               // merge vertices whose attributes are all equal
  // glTF only: >= 0 reads that node (with its children) instead of the default scene, e.g. level
  // k of a LOD chain written by writeGltfLodChain (node k), which only lists node 0 in its scene.
  int gltf_node = -1;
};

// Reads any supported format, chosen by extension (case-insensitive): .gltf .glb .obj .ply .off.
// Afterwards the mesh is validated (core::validateMesh), welded, and normals/tangents generated as
// the options ask. An asset with no triangles is an error.
core::Result<core::Asset> loadAsset(const std::string& path, const LoadOptions& options = {});

// The format readers. They fill positions/attributes/indices/submeshes/materials/textures as found
// in the file and do no post-processing (loadAsset does that).
core::Result<core::Asset> readGltf(const std::string& path, const LoadOptions& options);
core::Result<core::Asset> readObj(const std::string& path, const LoadOptions& options);
core::Result<core::Asset> readPly(const std::string& path, const LoadOptions& options);
core::Result<core::Asset> readOff(const std::string& path, const LoadOptions& options);

// Writers. Output is written atomically (temporary file in the same folder, then rename) and no
// file written (the document, .bin, .mtl, textures) replaces one the asset was read from
// (refuseSourceFile). writeGltf picks .gltf (+ .bin and textures beside it)
// or .glb (everything embedded) by extension. Textures are written by textureFile: the PNG or
// JPEG bytes they were read from while unchanged, else PNG.
// The files of one output are written all or nothing (FileSet). With `replace_existing` false, a
// file that exists is not replaced: the document's, or one written beside it.
struct WriteOptions {
  bool replace_existing = true;
};
core::Status writeGltf(const core::Asset& asset, const std::string& path,
                       const WriteOptions& options = {});
core::Status writeObj(const core::Asset& asset, const std::string& path,
                      const WriteOptions& options = {});

// The LOD chain as one glTF (.gltf or .glb): one node per level, all sharing the asset's
// materials and textures. Each node has its own mesh, except that levels whose meshes are equal
// (levels that change only the shader) share the first one's glTF mesh, stored once. Node 0 (level
// 0) lists the coarser nodes in its MSFT_lod extension and `extras.MSFT_screencoverage` holds one
// value per level: the screen-area fraction below which the next level takes over (the last is 0).
// Only node 0 is in the scene. Requires one coverage per level, decreasing; `level_meshes` replace
// asset.mesh.
core::Status writeGltfLodChain(const core::Asset& asset, std::span<const core::Mesh> level_meshes,
                               std::span<const double> screen_coverage, const std::string& path);

// lod.json, the policy the runtime (include/duolod/runtime.hpp) reads; see that header for the
// fields it needs. Costs are in the unit `cost_unit` names; absent values are written as null.
struct LodJsonLevel {
  int level = 0;
  double distance = 0;          // d_i the level was optimized at
  double switch_distance = 0;   // from here on this level is used (0 for level 0)
  double screen_coverage = 1;   // screen-area fraction at switch_distance (1 for level 0)
  size_t triangles = 0, vertices = 0;
  std::string mesh_file;
  std::string shader_summary;   // in words
  std::vector<std::pair<std::string, std::string>> shader_files;  // kind -> file name
  // Uniforms the CPU sets for this level's shader (moving to parameter, He et al. 2015): a
  // default-block uniform at `location` with value.size() components (float .. vec4).
  struct Parameter {
    std::string name;
    int location = 0;
    std::vector<float> value;
  };
  std::vector<Parameter> shader_parameters;
  double error = 0, error_bound = 0;        // ε_a and e_a(d_i)·s_d (eq. 3)
  std::optional<double> transition_error;   // ε_t to the next level (eq. 5); none for the last
  std::optional<double> predicted_cost, measured_cost;
};
struct LodJsonDocument {
  std::string asset_name, asset_source;
  core::Sphere bounds;  // the original's: distances are measured from its centre
  // Around bounds.center, the radius that holds every level's vertices (an optimal placement may
  // move a vertex a little outside the original's sphere): for culling. 0: bounds.radius.
  double culling_radius = 0;
  float fov_y_deg = 45, screen_aspect = 16.0f / 9.0f;
  int screen_height_px = 1080;
  double d_near = 0, d_far = 0, q = 0, e_max = 0;  // eq. (4)
  double time_tolerance = 0, merge_min_gain = 0;   // T (Algorithm 2), W (§6.2)
  std::string views = "sphere";                     // training views: "sphere" or "upright"
  std::string optimizer, cost_source, cost_unit;   // e.g. "separate", "measured", "ms"
  std::vector<LodJsonLevel> levels;
  // Olano's single LOD shader (autolod.*): `uniform` at `location` set to k runs level k; its
  // parameters are every level's, under the names the shader declares (which may differ from the
  // level's own files: a clash moved or renamed them).
  struct AutoLod {
    std::vector<std::pair<std::string, std::string>> files;  // kind -> file name
    std::string uniform = "autoLOD";
    int location = 39;
    std::vector<LodJsonLevel::Parameter> parameters;
  };
  std::optional<AutoLod> autolod;
};
std::string lodJsonText(const LodJsonDocument& document);
// Checks what the runtime relies on (levels present, switch distances increasing, coverages in
// [0, 1] decreasing, parameters with a location in [0, 65535] and 1-4 finite values) and writes
// atomically.
core::Status writeLodJson(const LodJsonDocument& document, const std::string& path);

// An error when `output` is one of the files `asset` was read from (Asset::source_files or its
// source_path, however spelled): what every writer checks before it writes a file.
core::Status refuseSourceFile(const core::Asset& asset, const std::string& output);

// Images.
core::Result<core::ImageRGBA8> readImage(const std::string& path);  // PNG, JPEG, ... via stb
core::Result<core::ImageRGBA8> decodeImage(std::span<const uint8_t> bytes, const std::string& name);
core::Status writePng(const core::ImageRGBA8& image, const std::string& path);
// Empty when the image is not valid (core::validateImage) or stb fails.
std::vector<uint8_t> encodePng(const core::ImageRGBA8& image);
// The bytes of a PNG or JPEG file, kept beside the image decoded from them (core::EncodedImage);
// null for other formats (glTF takes only PNG and JPEG: the writers encode those as PNG).
std::shared_ptr<const core::EncodedImage> keepEncoded(std::span<const uint8_t> bytes,
                                                      const core::ImageRGBA8& decoded);
// The bytes of a PNG or JPEG file with the size its header gives, no pixels kept; null for other
// formats and for a PNG or JPEG whose chunks or segments are damaged (a CRC wrong, cut short):
// the caller decodes those instead, to accept or refuse them as decoding does. A JPEG has no
// checksum, so one with whole segments is decoded here to be checked. An error (`name` says which
// file) when the header cannot be read or stb does not decode such a JPEG.
core::Result<std::shared_ptr<const core::EncodedImage>> keepUndecoded(
    std::span<const uint8_t> bytes, const std::string& name);
// A texture file read, its bytes kept (keepEncoded); decoded unless `decode` is false and it is
// a PNG or JPEG (keepUndecoded). `name` is the path.
core::Result<core::Texture> readTextureFile(const std::string& path, bool srgb, bool decode = true);
// A texture as the writers store it: the bytes it was read from while its image is unchanged
// (same fingerprint) or was never decoded, otherwise the image encoded as PNG (empty bytes if
// that fails).
struct TextureFile {
  std::vector<uint8_t> bytes;
  std::string mime_type;  // "image/png" or "image/jpeg"
  std::string extension;  // ".png" or ".jpg"
  bool copied = false;    // the source's bytes, not encoded again
};
TextureFile textureFile(const core::Texture& texture);

// Files.
core::Result<std::vector<uint8_t>> readFileBytes(const std::string& path);
// Writes to PATH.tmp-XXXX then renames over PATH, so a reader never sees a partial file.
core::Status writeFileAtomic(const std::string& path, std::span<const uint8_t> bytes);
core::Status writeFileAtomic(const std::string& path, std::string_view text);

// Files written together (a .gltf with its .bin and textures, an .obj with its .mtl): add() writes
// each to a temporary file beside its target, commit() renames them all into place. All or
// nothing: a failure before commit (a full disk, a target that is a folder) leaves no file of the
// set (the temporaries of a set that is not committed are removed when it is destroyed), and a
// rename that fails part-way through commit() puts back the files the earlier renames replaced
// (each kept as a hard link, or a copy, until the set is in place) and removes the ones they
// created. With `replace_existing` false, add() refuses a target that exists.
class FileSet {
 public:
  explicit FileSet(bool replace_existing = true) : replace_existing_(replace_existing) {}
  FileSet(const FileSet&) = delete;
  FileSet& operator=(const FileSet&) = delete;
  ~FileSet();
  core::Status add(const std::string& path, std::span<const uint8_t> bytes);
  core::Status add(const std::string& path, std::string_view text);
  // A file already written elsewhere on the same file system, moved to `path` by commit() (and
  // removed with the set if it is not committed). Whether `path` can take it is found by the
  // rename in commit(), which then puts back what it had moved.
  core::Status adopt(const std::string& written, const std::string& path);
  core::Status commit();

 private:
  core::Status checkTarget(const std::string& path) const;
  struct Staged {
    std::string temporary, target;
    uint64_t token;  // in the unfinished outputs (removeUnfinishedOutputsOnInterrupt), or 0
  };
  bool replace_existing_;
  std::vector<Staged> staged_;
};

// An output folder written all or nothing (`duolod generate`'s and `duolod shader`'s): its files
// are written into a hidden staging folder inside it (stagingPath(); inside, so that it is on the
// folder's file system even when the folder is a mount point), and commit() moves them into the
// folder as one FileSet. A failed commit leaves the folder as it was (with the files it held
// before; a folder, and parents, that begin() made are removed again); a staging folder that is
// not committed is removed with everything in it. Files the folder holds and this output does not
// write are kept.
class OutputFolder {
 public:
  OutputFolder() = default;
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  ~OutputFolder();
  // Creates the folder (and its missing parents) and the staging folder inside it.
  core::Status begin(const std::string& folder);
  const std::string& stagingPath() const { return staging_; }
  // Moves the staged files into the folder. No file may replace one `asset` was read from
  // (refuseSourceFile), when given.
  core::Status commit(const core::Asset* asset = nullptr);

 private:
  void abandon();
  void forgetUnfinished();
  std::string folder_, staging_;
  std::vector<std::string> created_;  // by begin(), innermost first
  std::vector<uint64_t> unfinished_;  // removeUnfinishedOutputsOnInterrupt's entries
};

// Checks, before any work, that files can be written at `path`: its folder exists, is a folder
// and takes a new file (a probe file is created and removed), and `path` itself is not a folder.
core::Status checkWritablePath(const std::string& path);
// The same for an output folder (OutputFolder): `folder` is a folder or does not exist yet, and
// it, or the nearest existing folder above it, takes a new file.
core::Status checkWritableFolder(const std::string& folder);
// Whether an existing folder holds anything but the staging folders of OutputFolders (runs that
// were killed leave theirs; the next begin() removes them).
core::Result<bool> folderHoldsFiles(const std::string& folder);

// For programs: on SIGINT, SIGTERM or SIGHUP, removes the outputs this library has not finished
// writing (FileSet and writeFileAtomic temporaries, OutputFolder staging folders and the folders
// begin() made; a commit in progress is let finish first), says so on stderr (after "`program`: "
// when given), and ends the process
// with status 128 + the signal. Call it at the start of main, before any thread is started: the
// signals are blocked in the calling thread (so in every thread started later) and taken by a
// thread of its own. Without it, an interrupted run leaves those files; the next
// OutputFolder::begin in the same folder removes a staging folder whose process is gone.
void removeUnfinishedOutputsOnInterrupt(const std::string& program = "");

}  // namespace duolod::io
