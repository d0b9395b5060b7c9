// duolod io: asset readers (glTF 2.0 .gltf/.glb, OBJ+MTL, PLY, OFF), writers (glTF, OBJ), PNG, and
// atomic file output. Readers never crash on bad input: they return an Error naming the file and
// the problem (line, field or byte offset where known).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "duolod/core.hpp"

namespace duolod::io {

struct LoadOptions {
  bool load_textures = true;      // decode texture images (missing image files are an error)
  bool generate_normals = true;   // when the file has none
  bool generate_tangents = true;  // when the file has none but has normals and uv0
  bool weld = true;               // merge vertices whose attributes are all equal
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

// Writers. Output is written atomically (temporary file in the same folder, then rename) and never
// over the file the asset was read from. writeGltf picks .gltf (+ .bin and PNG textures beside it)
// or .glb (everything embedded) by extension.
core::Status writeGltf(const core::Asset& asset, const std::string& path);
core::Status writeObj(const core::Asset& asset, const std::string& path);

// Images.
core::Result<core::ImageRGBA8> readImage(const std::string& path);  // PNG, JPEG, ... via stb
core::Result<core::ImageRGBA8> decodeImage(std::span<const uint8_t> bytes, const std::string& name);
core::Status writePng(const core::ImageRGBA8& image, const std::string& path);
std::vector<uint8_t> encodePng(const core::ImageRGBA8& image);

// Files.
core::Result<std::vector<uint8_t>> readFileBytes(const std::string& path);
// Writes to PATH.tmp-XXXX then renames over PATH, so a reader never sees a partial file.
core::Status writeFileAtomic(const std::string& path, std::span<const uint8_t> bytes);
core::Status writeFileAtomic(const std::string& path, std::string_view text);

}  // namespace duolod::io
