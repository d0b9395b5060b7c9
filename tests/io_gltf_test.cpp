// glTF reader/writer tests: the real Khronos samples (counts, materials, textures, colour spaces),
// a write → read round trip through .gltf and .glb, small hand-made files with known answers
// (node transforms, mirroring, submeshes, index types, normalized colours), and malformed files,
// each of which must come back as an Error naming the file, never a crash.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>

#include "duolod/io.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;
using core::Vec3;
using nlohmann::json;

constexpr int kUnsignedByte = 5121;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kFloat = 5126;

std::string base64(const std::vector<uint8_t>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t chunk = uint32_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) chunk |= uint32_t(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) chunk |= bytes[i + 2];
    out += kAlphabet[(chunk >> 18) & 63];
    out += kAlphabet[(chunk >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(chunk >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[chunk & 63] : '=';
  }
  return out;
}

using test::writeBytes;

// A hand-made glTF: one binary buffer built view by view, and the JSON document around it.
struct HandGltf {
  json doc = {{"asset", {{"version", "2.0"}}}};
  std::vector<uint8_t> bin;

  // Appends bytes as a new bufferView, 4-byte aligned; returns its index.
  int addView(const void* data, size_t size, size_t byte_stride = 0) {
    while (bin.size() % 4) bin.push_back(0);
    json view = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", size}};
    if (byte_stride) view["byteStride"] = byte_stride;
    const auto* bytes = static_cast<const uint8_t*>(data);
    bin.insert(bin.end(), bytes, bytes + size);
    doc["bufferViews"].push_back(view);
    return int(doc["bufferViews"].size()) - 1;
  }
  template <class T>
  int addView(const std::vector<T>& values, size_t byte_stride = 0) {
    return addView(values.data(), values.size() * sizeof(T), byte_stride);
  }
  int addAccessor(int view, int component_type, size_t count, const std::string& type,
                  json extra = json::object()) {
    json accessor = {
        {"bufferView", view}, {"componentType", component_type}, {"count", count}, {"type", type}};
    accessor.update(extra);
    doc["accessors"].push_back(accessor);
    return int(doc["accessors"].size()) - 1;
  }
  // Float data as a view plus an accessor over all of it.
  int addFloats(const std::vector<float>& values, const std::string& type) {
    size_t components = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : 4;
    return addAccessor(addView(values), kFloat, values.size() / components, type);
  }
  template <class T>
  int addIndices(const std::vector<T>& indices, int component_type) {
    return addAccessor(addView(indices), component_type, indices.size(), "SCALAR");
  }
  // Adds a mesh with the given primitives; returns its index.
  int addMesh(json primitives) {
    doc["meshes"].push_back({{"primitives", primitives}});
    return int(doc["meshes"].size()) - 1;
  }
  int addNode(json node) {
    doc["nodes"].push_back(node);
    return int(doc["nodes"].size()) - 1;
  }
  void setScene(json root_nodes) {
    doc["scene"] = 0;
    doc["scenes"] = json::array({{{"nodes", root_nodes}}});
  }

  // Writes NAME.gltf into `dir` with the buffer as NAME.bin beside it, or embedded as a base64
  // data: URI. A "buffers" entry already in the document is kept as it is.
  std::string write(const fs::path& dir, const std::string& name, bool embed = false) const {
    json out = doc;
    if (!out.contains("buffers") && !bin.empty()) {
      std::string uri =
          embed ? "data:application/octet-stream;base64," + base64(bin) : name + ".bin";
      out["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", uri}}});
    }
    if (!embed && !bin.empty()) writeBytes(dir / (name + ".bin"), bin);
    fs::path path = dir / (name + ".gltf");
    std::ofstream(path) << out.dump(2);
    return path.string();
  }
};

json primitive(int positions, int indices = -1, int material = -1,
               json other_attributes = json::object()) {
  json attributes = {{"POSITION", positions}};
  attributes.update(other_attributes);
  json prim = {{"attributes", attributes}};
  if (indices >= 0) prim["indices"] = indices;
  if (material >= 0) prim["material"] = material;
  return prim;
}

// One triangle (0,0,0) (1,0,0) (0,1,0), counter-clockwise seen from +z, on node 0 of scene 0.
HandGltf oneTriangle() {
  HandGltf g;
  int positions = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  int indices = g.addIndices(std::vector<uint32_t>{0, 1, 2}, kUnsignedInt);
  g.addNode({{"mesh", g.addMesh({primitive(positions, indices)})}});
  g.setScene({0});
  return g;
}

// A small asset built in memory (a unit quad with one red material), for writer tests.
core::Asset quadAsset() {
  core::Asset asset;
  asset.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  asset.mesh.normals.assign(4, Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  core::Material red;
  red.name = "red";
  red.base_color_factor = {1, 0, 0, 1};
  asset.materials = {red};
  return asset;
}

// Loading `path` must fail with a message that names the file (and contains `fragment`).
void expectLoadError(const std::string& path, const std::string& fragment = "") {
  auto loaded = io::loadAsset(path);
  ASSERT_FALSE(loaded) << path << " loaded although it is malformed";
  const std::string& message = loaded.error().message;
  EXPECT_NE(message.find(fs::path(path).filename().string()), std::string::npos)
      << "message does not name the file: " << message;
  if (!fragment.empty()) {
    EXPECT_NE(message.find(fragment), std::string::npos)
        << "expected '" << fragment << "' in: " << message;
  }
}

using test::hasWarningContaining;

// ---------------------------------------------------------------------------------------------
// Real assets.

TEST(GltfSamples, WaterBottleCountsMaterialAndTextures) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  const core::Mesh& mesh = asset->mesh;
  EXPECT_EQ(mesh.triangleCount(), 4510u);
  EXPECT_TRUE(core::validateMesh(mesh));
  EXPECT_EQ(mesh.tangents.size(), mesh.vertexCount());  // from the file
  EXPECT_EQ(mesh.normals.size(), mesh.vertexCount());
  EXPECT_EQ(mesh.uv0.size(), mesh.vertexCount());
  ASSERT_EQ(asset->materials.size(), 1u);
  const core::Material& m = asset->materials[0];
  EXPECT_EQ(m.name, "BottleMat");
  // Five texture slots are used; occlusion and metallic-roughness share one packed ORM image, so
  // the file has four distinct textures.
  EXPECT_GE(m.base_color_texture, 0);
  EXPECT_GE(m.metallic_roughness_texture, 0);
  EXPECT_GE(m.normal_texture, 0);
  EXPECT_GE(m.occlusion_texture, 0);
  EXPECT_GE(m.emissive_texture, 0);
  EXPECT_EQ(m.occlusion_texture, m.metallic_roughness_texture);
  ASSERT_EQ(asset->textures.size(), 4u);
  for (const core::Texture& t : asset->textures) {
    EXPECT_EQ(t.image.width, 2048) << t.name;
    EXPECT_EQ(t.image.height, 2048) << t.name;
    EXPECT_EQ(t.image.pixels.size(), 2048u * 2048u * 4u) << t.name;
  }
  EXPECT_TRUE(asset->textures[m.base_color_texture].srgb);
  EXPECT_TRUE(asset->textures[m.emissive_texture].srgb);
  EXPECT_FALSE(asset->textures[m.metallic_roughness_texture].srgb);
  EXPECT_FALSE(asset->textures[m.normal_texture].srgb);
  EXPECT_EQ(m.emissive_factor, (Vec3{1, 1, 1}));
}

TEST(GltfSamples, AvocadoTriangleCount) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/Avocado/Avocado.gltf");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  EXPECT_EQ(asset->mesh.triangleCount(), 682u);
  EXPECT_EQ(asset->textures.size(), 3u);
  EXPECT_TRUE(core::validateMesh(asset->mesh));
}

void expectSameMaterial(const core::Material& a, const core::Material& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.base_color_factor.x, b.base_color_factor.x);
  EXPECT_EQ(a.base_color_factor.y, b.base_color_factor.y);
  EXPECT_EQ(a.base_color_factor.z, b.base_color_factor.z);
  EXPECT_EQ(a.base_color_factor.w, b.base_color_factor.w);
  EXPECT_EQ(a.metallic_factor, b.metallic_factor);
  EXPECT_EQ(a.roughness_factor, b.roughness_factor);
  EXPECT_EQ(a.emissive_factor, b.emissive_factor);
  EXPECT_EQ(a.normal_scale, b.normal_scale);
  EXPECT_EQ(a.occlusion_strength, b.occlusion_strength);
  EXPECT_EQ(a.alpha_mode, b.alpha_mode);
  EXPECT_EQ(a.double_sided, b.double_sided);
  EXPECT_EQ(a.base_color_texture, b.base_color_texture);
  EXPECT_EQ(a.metallic_roughness_texture, b.metallic_roughness_texture);
  EXPECT_EQ(a.normal_texture, b.normal_texture);
  EXPECT_EQ(a.occlusion_texture, b.occlusion_texture);
  EXPECT_EQ(a.emissive_texture, b.emissive_texture);
}

std::vector<std::string> temporaryFilesIn(const fs::path& dir) {
  std::vector<std::string> found;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename().string().find(".tmp-") != std::string::npos)
      found.push_back(entry.path().filename().string());
  return found;
}

// Works on a scratch copy of the sample so that a writer bug can never damage the shared asset.
TEST(GltfRoundTrip, WaterBottleThroughGltfAndGlb) {
  DUOLOD_REQUIRE_ASSET(source, "gltf/WaterBottle/WaterBottle.gltf");
  fs::path copy = test::scratchDir("copy");
  fs::copy(fs::path(source).parent_path(), copy);
  std::string input = (copy / "WaterBottle.gltf").string();
  auto original = io::loadAsset(input);
  ASSERT_TRUE(original) << original.error().message;

  // The writer refuses the file the asset came from, however it is spelled, and leaves it alone.
  std::vector<uint8_t> input_bytes = test::readBytes(input);
  auto over_source = io::writeGltf(*original, original->source_path);
  EXPECT_FALSE(over_source);
  auto over_alias = io::writeGltf(*original, (copy / ".." / "copy" / "WaterBottle.gltf").string());
  EXPECT_FALSE(over_alias);
  EXPECT_EQ(test::readBytes(input), input_bytes);

  fs::path out = test::scratchDir("out");
  for (const char* name : {"bottle.gltf", "bottle.glb"}) {
    SCOPED_TRACE(name);
    std::string path = (out / name).string();
    auto written = io::writeGltf(*original, path);
    ASSERT_TRUE(written) << written.error().message;
    auto reloaded = io::loadAsset(path);
    ASSERT_TRUE(reloaded) << reloaded.error().message;
    const core::Mesh& a = original->mesh;
    const core::Mesh& b = reloaded->mesh;
    EXPECT_EQ(b.triangleCount(), a.triangleCount());
    ASSERT_EQ(b.vertexCount(), a.vertexCount());
    size_t differing = 0;
    for (size_t v = 0; v < a.vertexCount(); ++v)
      if (std::memcmp(&a.positions[v], &b.positions[v], sizeof(Vec3)) != 0) ++differing;
    EXPECT_EQ(differing, 0u) << "positions are not bitwise equal after the round trip";
    EXPECT_EQ(b.indices, a.indices);
    EXPECT_EQ(b.tangents.size(), b.vertexCount());
    ASSERT_EQ(reloaded->materials.size(), original->materials.size());
    expectSameMaterial(reloaded->materials[0], original->materials[0]);
    ASSERT_EQ(reloaded->textures.size(), original->textures.size());
    for (size_t t = 0; t < original->textures.size(); ++t) {
      EXPECT_EQ(reloaded->textures[t].image.width, original->textures[t].image.width);
      EXPECT_EQ(reloaded->textures[t].image.height, original->textures[t].image.height);
      EXPECT_EQ(reloaded->textures[t].srgb, original->textures[t].srgb);
      EXPECT_TRUE(reloaded->textures[t].image.pixels == original->textures[t].image.pixels)
          << "texture " << t << " changed (PNG is lossless)";
    }
    // Writing over the reloaded file's own path is refused too.
    EXPECT_FALSE(io::writeGltf(*reloaded, path));
  }
  EXPECT_TRUE(fs::exists(out / "bottle.bin"));
  EXPECT_EQ(temporaryFilesIn(out), std::vector<std::string>{});
  EXPECT_EQ(temporaryFilesIn(copy), std::vector<std::string>{});
}

TEST(GltfWriter, RefusesSourcePathOfHandMadeFileAndBadExtension) {
  fs::path dir = test::scratchDir("w");
  std::string path = oneTriangle().write(dir, "tri");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  std::vector<uint8_t> before = test::readBytes(path);
  auto refused = io::writeGltf(*asset, path);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("tri.gltf"), std::string::npos) << refused.error().message;
  EXPECT_EQ(test::readBytes(path), before);
  EXPECT_FALSE(io::writeGltf(*asset, (dir / "tri.obj").string()));
  auto no_folder = io::writeGltf(*asset, (dir / "missing" / "x.glb").string());
  EXPECT_FALSE(no_folder);
  EXPECT_FALSE(fs::exists(dir / "missing"));
  EXPECT_EQ(temporaryFilesIn(dir), std::vector<std::string>{});
}

TEST(GltfWriter, OverwritesAnEarlierOutputAtomically) {
  fs::path dir = test::scratchDir("w");
  std::string path = (dir / "quad.glb").string();
  core::Asset asset = quadAsset();
  ASSERT_TRUE(io::writeGltf(asset, path));
  asset.materials[0].base_color_factor = {0, 1, 0, 1};
  ASSERT_TRUE(io::writeGltf(asset, path));
  auto reloaded = io::loadAsset(path);
  ASSERT_TRUE(reloaded) << reloaded.error().message;
  EXPECT_EQ(reloaded->materials[0].base_color_factor.y, 1.0f);
  EXPECT_EQ(temporaryFilesIn(dir), std::vector<std::string>{});
}

// quadAsset with a 2×2 base colour texture, so that a .gltf or .obj output has files beside it.
core::Asset texturedQuadAsset() {
  core::Asset asset = quadAsset();
  asset.mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  core::Texture texture;
  texture.name = "checker";
  texture.image = {2, 2, {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255}};
  texture.srgb = true;
  asset.textures = {texture};
  asset.materials[0].base_color_texture = 0;
  return asset;
}

std::vector<std::string> namesIn(const fs::path& dir) {
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The files of one output are written all or nothing: with a folder where the document goes,
// the .bin, the texture and the .mtl made before it are not left behind.
TEST(GltfWriter, AFailedWriteLeavesNoFileOfTheOutput) {
  const core::Asset asset = texturedQuadAsset();
  for (const char* blocked : {"out.gltf", "out.obj", "out.mtl"}) {
    fs::path dir = test::scratchDir(std::string("all_or_nothing_") + blocked);
    fs::create_directory(dir / blocked);
    const std::string path =
        (dir / (std::string(blocked) == "out.gltf" ? "out.gltf" : "out.obj")).string();
    auto written =
        test::contains(path, ".gltf") ? io::writeGltf(asset, path) : io::writeObj(asset, path);
    ASSERT_FALSE(written) << blocked;
    EXPECT_TRUE(test::contains(written.error().message, "is a folder")) << written.error().message;
    EXPECT_EQ(namesIn(dir), std::vector<std::string>{blocked}) << blocked;
  }
  // Without the folder in the way, the same writes make every file.
  fs::path dir = test::scratchDir("all_or_nothing_ok");
  ASSERT_TRUE(io::writeGltf(asset, (dir / "out.gltf").string()));
  ASSERT_TRUE(io::writeObj(asset, (dir / "out.obj").string()));
  // Both writers name the texture out_texture0.png (the same bytes).
  EXPECT_EQ(namesIn(dir), (std::vector<std::string>{"out.bin", "out.gltf", "out.mtl", "out.obj",
                                                    "out_texture0.png"}));
}

// Not replacing: a file beside the output that exists (an earlier .bin, someone's .mtl) is kept,
// and nothing of the output is written.
TEST(GltfWriter, ExistingFilesBesideTheOutputAreKeptUnlessReplacing) {
  const core::Asset asset = texturedQuadAsset();
  fs::path dir = test::scratchDir("keep_beside");
  for (const char* kept : {"out.bin", "out.mtl"}) {
    std::ofstream(dir / kept) << "precious";
    const std::string path =
        (dir / (std::string(kept) == "out.bin" ? "out.gltf" : "out.obj")).string();
    auto written = test::contains(path, ".gltf")
                       ? io::writeGltf(asset, path, {.replace_existing = false})
                       : io::writeObj(asset, path, {.replace_existing = false});
    ASSERT_FALSE(written) << kept;
    EXPECT_TRUE(test::contains(written.error().message, kept)) << written.error().message;
    EXPECT_TRUE(test::contains(written.error().message, "already exists"))
        << written.error().message;
    // A library error names no command-line flag (the CLI adds "--force").
    EXPECT_FALSE(test::contains(written.error().message, "--")) << written.error().message;
    EXPECT_EQ(test::readText(dir / kept), "precious");
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(io::writeGltf(asset, (dir / "replaced.gltf").string(), {.replace_existing = true}));
  }
  EXPECT_EQ(temporaryFilesIn(dir), std::vector<std::string>{});
}

// File names become URI references: a space, a '%' and UTF-8 are percent-encoded, so that a
// reader (ours, gltfpack, the validator) decodes them back to the files written.
TEST(GltfWriter, FileReferencesArePercentEncoded) {
  const core::Asset asset = texturedQuadAsset();
  fs::path dir = test::scratchDir("uri");
  const std::string path = (dir / "my model%20\xC3\xA9.gltf").string();
  ASSERT_TRUE(io::writeGltf(asset, path));
  const nlohmann::json document = nlohmann::json::parse(test::readText(path));
  EXPECT_EQ(document["buffers"][0]["uri"], "my%20model%2520%C3%A9.bin");
  EXPECT_TRUE(fs::exists(dir / "my model%20\xC3\xA9.bin"));
  auto reloaded = io::loadAsset(path);
  ASSERT_TRUE(reloaded) << reloaded.error().message;
  ASSERT_EQ(reloaded->textures.size(), 1u);
  EXPECT_EQ(reloaded->textures[0].image.width, 2);
  EXPECT_EQ(reloaded->mesh.triangleCount(), 2u);
  // Read without its textures, the image it names is still known as a file it was read from, by
  // its decoded name, so no writer replaces it.
  auto undecoded = io::loadAsset(path, {.load_textures = false});
  ASSERT_TRUE(undecoded) << undecoded.error().message;
  const std::string texture = (dir / "my model%20\xC3\xA9_texture0.png").string();
  ASSERT_TRUE(fs::exists(texture));
  EXPECT_FALSE(io::refuseSourceFile(*undecoded, texture));
}

// ---------------------------------------------------------------------------------------------
// Hand-made files with known answers.

TEST(GltfReader, EmbeddedDataUriBuffer) {
  std::string path = oneTriangle().write(test::scratchDir("g"), "tri", /*embed=*/true);
  auto asset = io::readGltf(path, {});
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->mesh.vertexCount(), 3u);
  EXPECT_EQ(asset->mesh.positions[1], (Vec3{1, 0, 0}));
  EXPECT_EQ(asset->mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
}

// parent: T = (1,2,3), R = 90° about +z; child: T = (0,0,1), S = (2,3,4).
// (1,1,1) → S (2,3,4) → T_child (2,3,5) → R: (x,y) → (−y,x) gives (−3,2,5) → T (−2,4,8).
TEST(GltfReader, NodeHierarchyTrsIsFlattened) {
  HandGltf g;
  int positions = g.addFloats({1, 1, 1, 0, 0, 0, 1, 0, 0}, "VEC3");
  int mesh = g.addMesh({primitive(positions)});
  float h = std::sqrt(0.5f);
  g.addNode({{"children", {1}}, {"translation", {1, 2, 3}}, {"rotation", {0, 0, h, h}}});
  g.addNode({{"mesh", mesh}, {"translation", {0, 0, 1}}, {"scale", {2, 3, 4}}});
  g.setScene({0});
  auto asset = io::readGltf(g.write(test::scratchDir("g"), "trs"), {});
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->mesh.vertexCount(), 3u);
  const auto& p = asset->mesh.positions;
  EXPECT_NEAR(p[0].x, -2, 1e-6);
  EXPECT_NEAR(p[0].y, 4, 1e-6);
  EXPECT_NEAR(p[0].z, 8, 1e-6);
  // (0,0,0) → (0,0,1) → (0,0,1) → (1,2,4).
  EXPECT_NEAR(p[1].x, 1, 1e-6);
  EXPECT_NEAR(p[1].y, 2, 1e-6);
  EXPECT_NEAR(p[1].z, 4, 1e-6);
}

// A column-major matrix node: scale 2 and translate (5,0,0).
TEST(GltfReader, NodeMatrixIsApplied) {
  HandGltf g;
  int positions = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  int mesh = g.addMesh({primitive(positions)});
  g.addNode({{"mesh", mesh}, {"matrix", {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 5, 0, 0, 1}}});
  g.setScene({0});
  auto asset = io::readGltf(g.write(test::scratchDir("g"), "matrix"), {});
  ASSERT_TRUE(asset) << asset.error().message;
  EXPECT_EQ(asset->mesh.positions[1], (Vec3{7, 0, 0}));
  EXPECT_EQ(asset->mesh.positions[2], (Vec3{5, 2, 0}));
}

// Mirroring x turns the triangle's winding clockwise; the reader must swap two corners so that the
// front face (counter-clockwise) still faces +z, where the transformed normal points, and flip
// the tangent's handedness (the bitangent +y stays +y while cross(n, t) flips).
TEST(GltfReader, MirroredNodeKeepsCounterClockwiseWinding) {
  HandGltf g;
  int positions = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  int normals = g.addFloats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
  int tangents = g.addFloats({1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1}, "VEC4");
  int indices = g.addIndices(std::vector<uint16_t>{0, 1, 2, 0}, kUnsignedShort);
  g.doc["accessors"][indices]["count"] = 3;  // the 4th short is padding
  int mesh =
      g.addMesh({primitive(positions, indices, -1, {{"NORMAL", normals}, {"TANGENT", tangents}})});
  g.addNode({{"mesh", mesh}, {"scale", {-1, 1, 1}}});
  g.setScene({0});
  auto asset = io::loadAsset(g.write(test::scratchDir("g"), "mirror"));
  ASSERT_TRUE(asset) << asset.error().message;
  const core::Mesh& m = asset->mesh;
  ASSERT_EQ(m.triangleCount(), 1u);
  Vec3 a = m.positions[m.indices[0]], b = m.positions[m.indices[1]], c = m.positions[m.indices[2]];
  Vec3 geometric = core::normalize(core::cross(b - a, c - a));
  EXPECT_NEAR(geometric.z, 1.0f, 1e-6f) << "winding flipped by the mirror";
  EXPECT_EQ(m.normals[m.indices[0]], (Vec3{0, 0, 1}));
  EXPECT_EQ(m.tangents[0].x, -1.0f);
  EXPECT_EQ(m.tangents[0].w, -1.0f);
  // The mirrored corner really is at x = -1.
  bool found = false;
  for (Vec3 p : m.positions) found |= p == Vec3{-1, 0, 0};
  EXPECT_TRUE(found);
}

// Primitive 0 uses material 1, primitive 1 material 0; submeshes come out in material order.
TEST(GltfReader, TwoPrimitivesWithDifferentMaterialsGiveTwoSubmeshes) {
  HandGltf g;
  int first = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  int second = g.addFloats({0, 0, 5, 1, 0, 5, 0, 1, 5}, "VEC3");
  int mesh = g.addMesh({primitive(first, -1, 1), primitive(second, -1, 0)});
  g.doc["materials"] = {
      {{"name", "red"}, {"pbrMetallicRoughness", {{"baseColorFactor", {1, 0, 0, 1}}}}},
      {{"name", "green"},
       {"pbrMetallicRoughness", {{"baseColorFactor", {0, 1, 0, 1}}, {"metallicFactor", 0.25}}}}};
  g.addNode({{"mesh", mesh}});
  g.setScene({0});
  auto asset = io::loadAsset(g.write(test::scratchDir("g"), "two"));
  ASSERT_TRUE(asset) << asset.error().message;
  const core::Mesh& m = asset->mesh;
  ASSERT_EQ(m.submeshes.size(), 2u);
  ASSERT_EQ(asset->materials.size(), 2u);
  EXPECT_EQ(asset->materials[1].name, "green");
  EXPECT_EQ(asset->materials[1].metallic_factor, 0.25f);
  for (const core::Submesh& sub : m.submeshes) {
    ASSERT_EQ(sub.index_count, 3u);
    float z = m.positions[m.indices[sub.first_index]].z;
    // material 0 (red) was on the z = 5 primitive, material 1 (green) on z = 0.
    EXPECT_EQ(z, sub.material == 0 ? 5.0f : 0.0f) << "submesh of material " << sub.material;
  }
  EXPECT_NE(m.submeshes[0].material, m.submeshes[1].material);
}

// Primitives that share their vertex accessors (duolod's writer gives every material of a level
// the level's one vertex accessor) are read once per placement: the mesh holds the accessor's
// vertices once, not once per primitive (2000 primitives over 8000 vertices made 16 million
// vertices and took seconds). A second placement of the mesh, under another node, is its own.
TEST(GltfReader, PrimitivesSharingAVertexAccessorShareTheirVertices) {
  constexpr int kPrimitives = 2000, kGrid = 64;  // a 64 x 64 vertex grid, one quad per primitive
  HandGltf g;
  std::vector<float> positions;
  for (int y = 0; y < kGrid; ++y)
    for (int x = 0; x < kGrid; ++x) positions.insert(positions.end(), {float(x), float(y), 0});
  int position_accessor = g.addFloats(positions, "VEC3");
  std::vector<uint32_t> indices;
  json primitives = json::array();
  for (int p = 0; p < kPrimitives; ++p) {
    uint32_t corner = uint32_t((p / (kGrid - 1)) * kGrid + p % (kGrid - 1));
    indices.insert(indices.end(), {corner, corner + 1, corner + kGrid + 1, corner,
                                   corner + kGrid + 1, corner + kGrid});
  }
  int index_view = g.addView(indices);
  for (int p = 0; p < kPrimitives; ++p) {
    int accessor = g.addAccessor(index_view, kUnsignedInt, 6, "SCALAR", {{"byteOffset", p * 24}});
    primitives.push_back(primitive(position_accessor, accessor, p));
    g.doc["materials"].push_back({{"name", "m" + std::to_string(p)}});
  }
  int mesh = g.addMesh(primitives);
  g.addNode({{"mesh", mesh}});
  g.addNode({{"mesh", mesh}, {"translation", {0, 0, 10}}, {"scale", {-1, 1, 1}}});
  g.setScene({0, 1});
  io::LoadOptions options;
  options.weld = false;
  options.generate_normals = options.generate_tangents = false;
  auto loaded = io::loadAsset(g.write(test::scratchDir("g"), "shared"), options);
  ASSERT_TRUE(loaded) << loaded.error().message;
  const core::Mesh& m = loaded->mesh;
  EXPECT_EQ(m.vertexCount(), size_t(2 * kGrid * kGrid)) << "the accessor once per node";
  EXPECT_EQ(m.triangleCount(), size_t(2 * 2 * kPrimitives));
  ASSERT_EQ(m.submeshes.size(), size_t(kPrimitives));
  for (const core::Submesh& sub : m.submeshes) {
    ASSERT_EQ(sub.index_count, 12u);
    const uint32_t p = sub.material;
    const float x = float(p % (kGrid - 1)), y = float(p / (kGrid - 1));
    // First node: untransformed, counter-clockwise from +z, its quad's corners.
    Vec3 a = m.positions[m.indices[sub.first_index]],
         b = m.positions[m.indices[sub.first_index + 1]],
         c = m.positions[m.indices[sub.first_index + 2]];
    EXPECT_EQ(a, (Vec3{x, y, 0})) << "material " << p;
    EXPECT_EQ(b, (Vec3{x + 1, y, 0})) << "material " << p;
    EXPECT_EQ(c, (Vec3{x + 1, y + 1, 0})) << "material " << p;
    // Second node: mirrored in x and lifted; its winding is swapped back to counter-clockwise.
    Vec3 d = m.positions[m.indices[sub.first_index + 6]],
         e = m.positions[m.indices[sub.first_index + 7]];
    EXPECT_EQ(d, (Vec3{-x, y, 10})) << "material " << p;
    EXPECT_EQ(e, (Vec3{-x - 1, y + 1, 10})) << "material " << p;
  }
}

TEST(GltfReader, PrimitiveWithoutIndicesIsATriangleList) {
  HandGltf g;
  int positions = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 3, 0, 0, 2, 1, 0}, "VEC3");
  g.addNode({{"mesh", g.addMesh({primitive(positions)})}});
  g.setScene({0});
  auto asset = io::readGltf(g.write(test::scratchDir("g"), "noindex"), {});
  ASSERT_TRUE(asset) << asset.error().message;
  EXPECT_EQ(asset->mesh.indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
  // A default material is added for the primitive without one.
  ASSERT_EQ(asset->materials.size(), 1u);
  EXPECT_EQ(asset->mesh.submeshes[0].material, 0u);
}

// Strips and fans in the specification's triangle order (§3.7.2.1), every triangle turning as the
// first; points and lines are skipped with a warning; a mode outside 0-6 is an error.
TEST(GltfReader, StripsAndFansAreReadAsTriangles) {
  // Four vertices of a unit square, in strip order and in fan order.
  for (auto [mode, expected] : {std::pair{5, std::vector<uint32_t>{0, 1, 2, 1, 3, 2}},
                                std::pair{6, std::vector<uint32_t>{1, 2, 0, 2, 3, 0}}}) {
    SCOPED_TRACE(mode);
    HandGltf g;
    int positions = g.addFloats(mode == 5 ? std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}
                                          : std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0},
                                "VEC3");
    json prim = primitive(positions);
    prim["mode"] = mode;
    g.addNode({{"mesh", g.addMesh({prim})}});
    g.setScene({0});
    auto asset = io::readGltf(g.write(test::scratchDir("g"), "strip"), {});
    ASSERT_TRUE(asset) << asset.error().message;
    EXPECT_EQ(asset->mesh.indices, expected);
  }
  for (int mode : {1, 99}) {
    HandGltf g;
    int positions = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
    json prim = primitive(positions);
    prim["mode"] = mode;
    g.addNode({{"mesh", g.addMesh({prim})}});
    g.setScene({0});
    auto asset = io::loadAsset(g.write(test::scratchDir("g"), "lines"), {});
    ASSERT_FALSE(asset);
    EXPECT_NE(
        asset.error().message.find(mode == 1 ? "no triangles (" : "not a glTF primitive mode"),
        std::string::npos)
        << asset.error().message;
    if (mode == 1) {
      EXPECT_NE(asset.error().message.find("(lines)"), std::string::npos);
    }
  }
}

TEST(GltfReader, UnsignedByteAndUnsignedShortIndices) {
  HandGltf g;
  int positions = g.addFloats({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, "VEC3");
  int byte_indices = g.addIndices(std::vector<uint8_t>{0, 1, 2, 0, 2, 3}, kUnsignedByte);
  int short_indices = g.addIndices(std::vector<uint16_t>{3, 2, 1, 3, 1, 0}, kUnsignedShort);
  g.doc["materials"] = {{{"name", "a"}}, {{"name", "b"}}};
  int mesh =
      g.addMesh({primitive(positions, byte_indices, 0), primitive(positions, short_indices, 1)});
  g.addNode({{"mesh", mesh}});
  g.setScene({0});
  auto asset = io::readGltf(g.write(test::scratchDir("g"), "indices"), {});
  ASSERT_TRUE(asset) << asset.error().message;
  // The primitives share their POSITION accessor, so they share its 4 vertices.
  EXPECT_EQ(asset->mesh.vertexCount(), 4u);
  EXPECT_EQ(asset->mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 3, 2, 1, 3, 1, 0}));
}

TEST(GltfReader, NormalizedUnsignedByteColorsAreInZeroOne) {
  HandGltf g;
  int positions = g.addFloats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  std::vector<uint8_t> rgba = {255, 0, 128, 255, 0, 255, 64, 255, 51, 102, 153, 204};
  int colors = g.addAccessor(g.addView(rgba), kUnsignedByte, 3, "VEC4", {{"normalized", true}});
  g.addNode({{"mesh", g.addMesh({primitive(positions, -1, -1, {{"COLOR_0", colors}})})}});
  g.setScene({0});
  auto asset = io::readGltf(g.write(test::scratchDir("g"), "colors"), {});
  ASSERT_TRUE(asset) << asset.error().message;
  const auto& c = asset->mesh.colors;
  ASSERT_EQ(c.size(), 3u);
  for (size_t v = 0; v < 3; ++v) {
    const float* channel = &c[v].x;
    for (int k = 0; k < 4; ++k) {
      EXPECT_FLOAT_EQ(channel[k], rgba[v * 4 + k] / 255.0f) << "vertex " << v << " channel " << k;
      EXPECT_GE(channel[k], 0.0f);
      EXPECT_LE(channel[k], 1.0f);
    }
  }
}

// A material whose base colour texture (a 2×2 PNG beside the file) carries KHR_texture_transform.
HandGltf texturedTriangle(bool with_transform) {
  HandGltf g = oneTriangle();
  json texture_ref = {{"index", 0}};
  if (with_transform) texture_ref["extensions"] = {{"KHR_texture_transform", {{"scale", {2, 2}}}}};
  g.doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", texture_ref}}}}};
  g.doc["meshes"][0]["primitives"][0]["material"] = 0;
  g.doc["textures"] = {{{"source", 0}}};
  g.doc["images"] = {{{"uri", "checker.png"}}};
  if (with_transform) g.doc["extensionsUsed"] = {"KHR_texture_transform"};
  return g;
}

TEST(GltfReader, TextureTransformIsAWarning) {
  fs::path dir = test::scratchDir("g");
  core::ImageRGBA8 checker{
      2, 2, {0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255}};
  ASSERT_TRUE(io::writePng(checker, (dir / "checker.png").string()));
  auto asset = io::loadAsset(texturedTriangle(true).write(dir, "transform"));
  ASSERT_TRUE(asset) << asset.error().message;
  EXPECT_TRUE(hasWarningContaining(*asset, "KHR_texture_transform"));
  ASSERT_EQ(asset->textures.size(), 1u);
  EXPECT_EQ(asset->textures[0].image.width, 2);
  EXPECT_TRUE(asset->textures[0].srgb);
  auto plain = io::loadAsset(texturedTriangle(false).write(dir, "plain"));
  ASSERT_TRUE(plain) << plain.error().message;
  EXPECT_FALSE(hasWarningContaining(*plain, "KHR_texture_transform"));
  EXPECT_FALSE(hasWarningContaining(*plain, "outside the asset's folder"));
}

// A uri that leaves the asset's folder is read (the spec allows it) and said: a pipeline that
// converts files it did not make would copy what it names into its outputs unawares.
TEST(GltfReader, UrisOutsideTheAssetsFolderAreWarnedAbout) {
  fs::path dir = test::scratchDir("g_outside");
  core::ImageRGBA8 checker{2, 2, std::vector<uint8_t>(16, 255)};
  ASSERT_TRUE(io::writePng(checker, (dir / "checker.png").string()));
  fs::create_directories(dir / "sub");
  HandGltf g = texturedTriangle(false);
  g.doc["images"] = {{{"uri", "../checker.png"}}};
  auto asset = io::loadAsset(g.write(dir / "sub", "up"));
  ASSERT_TRUE(asset) << asset.error().message;
  EXPECT_TRUE(
      hasWarningContaining(*asset, "image 0's uri '../checker.png' is outside the asset's folder"));
  EXPECT_EQ(asset->textures.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// Malformed files: an Error naming the file, never a crash.

TEST(GltfMalformed, TruncatedJson) {
  fs::path dir = test::scratchDir("m");
  std::string path = oneTriangle().write(dir, "cut");
  std::vector<uint8_t> bytes = test::readBytes(path);
  bytes.resize(bytes.size() / 2);
  writeBytes(path, bytes);
  expectLoadError(path);
}

// A .glb that is not one says so (it was parsed as JSON: a parser error quoting a binary byte),
// an empty file is "empty" once, and a texture that is not there names the file looked for.
TEST(GltfMalformed, MessagesSayWhatIsWrong) {
  fs::path dir = test::scratchDir("m_messages");
  writeBytes((dir / "garbage.glb").string(), {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a, 0, 0});
  expectLoadError((dir / "garbage.glb").string(), "not a GLB file");
  writeBytes((dir / "empty.gltf").string(), {});
  auto empty = io::loadAsset((dir / "empty.gltf").string());
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error().message, (dir / "empty.gltf").string() + ": file is empty");
  std::string textured = texturedTriangle(false).write(dir, "no_texture");  // no checker.png
  expectLoadError(textured, (dir / "checker.png").string() + " does not exist");
}

// Found by fuzzing. JSON nested past what tinygltf's recursive copy of `extras` survives (a stack
// overflow at 20,000 levels) is refused; values outside the spec are refused when nothing can be
// made of them (an infinite factor was written out as `inf`, which no reader takes; a 32-bit
// integer position was read as coordinates of 1e9) and repaired with a warning otherwise (a
// rotation of length 100 stretched the mesh 19,999 times; factors out of range were passed on).
TEST(GltfMalformed, ValuesOutsideTheSpecAreRefusedOrRepaired) {
  const fs::path dir = test::scratchDir("m_spec");
  {
    std::ofstream deep(dir / "deep.gltf");
    deep << R"({"asset": {"version": "2.0"}, "extras": )" << std::string(20000, '[')
         << std::string(20000, ']') << "}";
  }
  expectLoadError((dir / "deep.gltf").string(), "the JSON nests 20001 levels deep (at most 256");
  HandGltf nested = oneTriangle();
  json value = 1;
  for (int i = 0; i < 200; ++i) value = json::array({value});
  nested.doc["extras"] = value;
  auto loaded = io::loadAsset(nested.write(dir, "nested"));
  EXPECT_TRUE(loaded) << loaded.error().message;

  HandGltf infinite = oneTriangle();
  infinite.doc["materials"] = {{{"pbrMetallicRoughness", {{"roughnessFactor", 1e39}}}}};
  infinite.doc["meshes"][0]["primitives"][0]["material"] = 0;
  expectLoadError(infinite.write(dir, "infinite"),
                  "material 0: roughnessFactor is not a finite number");
  HandGltf out_of_range = infinite;
  out_of_range.doc["materials"] = {
      {{"pbrMetallicRoughness", {{"baseColorFactor", {7, -5, 2, 1}}, {"metallicFactor", -3}}}}};
  auto clamped = io::loadAsset(out_of_range.write(dir, "out_of_range"));
  ASSERT_TRUE(clamped) << clamped.error().message;
  const core::Material& material = clamped->materials[0];
  EXPECT_EQ(material.base_color_factor.x, 1.0f);
  EXPECT_EQ(material.base_color_factor.y, 0.0f);
  EXPECT_EQ(material.metallic_factor, 0.0f);
  EXPECT_TRUE(hasWarningContaining(
      *clamped, "material 0: baseColorFactor, metallicFactor out of the glTF range, clamped"));

  HandGltf integer_positions = oneTriangle();
  integer_positions.doc["accessors"][0]["componentType"] = kUnsignedInt;
  expectLoadError(integer_positions.write(dir, "integer_positions"),
                  "componentType 5125 (unsigned int) is not allowed for a vertex attribute");

  HandGltf rotated = oneTriangle();
  rotated.doc["nodes"][0]["rotation"] = {0, 100, 0, 0};  // 180° about y, 100 times too long
  auto normalized = io::loadAsset(rotated.write(dir, "rotated"));
  ASSERT_TRUE(normalized) << normalized.error().message;
  EXPECT_TRUE(
      hasWarningContaining(*normalized, "node 0: rotation has length 100, not 1; normalized"));
  for (const Vec3& p : normalized->mesh.positions) EXPECT_LE(core::length(p), 1.0001f);
  EXPECT_NEAR(normalized->mesh.positions[1].x, -1.0f, 1e-6f);
  HandGltf zero = oneTriangle();
  zero.doc["nodes"][0]["rotation"] = {0, 0, 0, 0};
  expectLoadError(zero.write(dir, "zero_rotation"),
                  "node 0: rotation (0, 0, 0, 0) is not a quaternion");
  HandGltf short_matrix = oneTriangle();
  short_matrix.doc["nodes"][0]["matrix"] = {1, 0, 0};
  expectLoadError(short_matrix.write(dir, "short_matrix"),
                  "node 0: matrix has 3 numbers (16 needed)");

  // Without indices, the count is of vertices.
  HandGltf four = oneTriangle();
  four.doc["accessors"][0]["count"] = 2;
  four.doc["meshes"][0]["primitives"][0].erase("indices");
  expectLoadError(four.write(dir, "two_vertices"),
                  "2 vertices (it has no indices) is not a whole number of triangles");
}

// A required extension that is not read, and glTF 1.0, are refused by name; a required
// KHR_mesh_quantization (any accessor component type is read) and an optional extension load.
TEST(GltfMalformed, RequiredExtensionsAndVersionAreHonoured) {
  fs::path dir = test::scratchDir("required");
  for (const char* extension : {"KHR_draco_mesh_compression", "KHR_texture_transform"}) {
    HandGltf g = oneTriangle();
    g.doc["extensionsUsed"] = {extension};
    g.doc["extensionsRequired"] = {extension};
    expectLoadError(g.write(dir, extension),
                    std::string("requires the glTF extension ") + extension);
  }
  HandGltf quantized = oneTriangle();
  quantized.doc["extensionsUsed"] = {"KHR_mesh_quantization", "MSFT_lod"};
  quantized.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
  auto loaded = io::loadAsset(quantized.write(dir, "quantized"));
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->mesh.triangleCount(), 1u);
  HandGltf old_version = oneTriangle();
  old_version.doc["asset"]["version"] = "1.0";
  expectLoadError(old_version.write(dir, "version1"), "glTF 2.0 only");
}

TEST(GltfMalformed, IndexOutOfRange) {
  HandGltf g = oneTriangle();
  // Replace the index data: 5 does not exist among 3 vertices.
  uint32_t bad[3] = {0, 1, 5};
  size_t offset = g.doc["bufferViews"][1]["byteOffset"];
  std::memcpy(g.bin.data() + offset, bad, sizeof(bad));
  expectLoadError(g.write(test::scratchDir("m"), "range"), "out of range");
}

TEST(GltfMalformed, AccessorCountLargerThanItsBufferView) {
  HandGltf g = oneTriangle();
  g.doc["accessors"][0]["count"] = 4;  // 4 × 12 bytes in a 36-byte view
  expectLoadError(g.write(test::scratchDir("m"), "count"), "do not fit");
}

// A broken accessor is named with the mesh (index and name), primitive and attribute that use it,
// and the bytes that do not fit. tinygltf's own messages named none of them ("primitive indices
// accessor out of bounds", "accessor[3] invalid bufferView"), nor did ours the mesh's name or the
// numbers ("NORMAL (accessor 3): 4 elements do not fit in the bufferView").
TEST(GltfMalformed, ErrorsNameTheMeshPrimitiveAndAttribute) {
  const fs::path dir = test::scratchDir("m_context");
  // Mesh 0 a plain triangle, mesh 1 'Body' the same triangle with normals, on two nodes.
  auto two_meshes = [] {
    HandGltf g = oneTriangle();
    const int normals = g.addFloats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
    g.doc["meshes"].push_back(
        {{"name", "Body"}, {"primitives", {primitive(0, 1, -1, {{"NORMAL", normals}})}}});
    g.addNode({{"mesh", 1}});
    g.setScene({0, 1});
    return g;
  };
  ASSERT_TRUE(io::loadAsset(two_meshes().write(dir, "good")).ok());
  auto expectMessage = [&](const HandGltf& g, const std::string& name, const std::string& text) {
    const std::string path = g.write(dir, name);
    auto loaded = io::loadAsset(path);
    ASSERT_FALSE(loaded.ok()) << name;
    EXPECT_EQ(loaded.error().message, path + ": " + text);
  };
  HandGltf normals = two_meshes();
  normals.doc["accessors"][2]["count"] = 4;  // 4 x 12 bytes from a 36-byte view
  expectMessage(normals, "normals",
                "mesh 1 'Body', primitive 0, attribute NORMAL: accessor 2 reads bytes 0-48 of "
                "bufferView 2 that holds 36: its 4 elements do not fit");
  HandGltf missing = two_meshes();
  missing.doc["meshes"][1]["primitives"][0]["indices"] = 7;
  expectMessage(missing, "missing_indices",
                "mesh 1 'Body', primitive 0, indices: accessor 7 does not exist (3 accessors)");
  HandGltf viewless = two_meshes();
  viewless.doc["accessors"][1].erase("bufferView");
  expectMessage(viewless, "viewless_indices",
                "mesh 0, primitive 0, indices: accessor 1 has no bufferView (data from sparse "
                "accessors or compression extensions is not supported)");
  HandGltf past = two_meshes();
  past.doc["bufferViews"][0]["byteLength"] = 400;
  expectMessage(past, "view_past_buffer",
                "mesh 0, primitive 0, attribute POSITION: accessor 0: bufferView 0 runs past the "
                "end of buffer 0 (offset 0 + length 400 > 84 bytes)");
}

TEST(GltfMalformed, BufferViewPastTheEndOfTheBuffer) {
  HandGltf g = oneTriangle();
  g.doc["bufferViews"][1]["byteLength"] = 400;
  expectLoadError(g.write(test::scratchDir("m"), "view"));
}

// Offsets near 2^64 must not wrap around in the bounds checks (offset + length → small).
TEST(GltfMalformed, OffsetsNearTwoToThe64DoNotWrapAround) {
  fs::path dir = test::scratchDir("m");
  const uint64_t kTop = UINT64_MAX;
  HandGltf g = oneTriangle();
  g.doc["bufferViews"][0]["byteOffset"] = uint64_t(1) << 63;
  g.doc["bufferViews"][0]["byteLength"] = uint64_t(1) << 63;
  expectLoadError(g.write(dir, "view_halves"), "past the end");

  g = oneTriangle();
  g.doc["bufferViews"][0]["byteOffset"] = kTop - 3;  // wraps to 36 with byteLength 40
  g.doc["bufferViews"][0]["byteLength"] = 40;
  expectLoadError(g.write(dir, "view_wrap"), "past the end");

  g = oneTriangle();
  g.doc["accessors"][0]["byteOffset"] = kTop - 7;  // would start 8 bytes before the view
  expectLoadError(g.write(dir, "accessor_wrap"), "do not fit");
}

// Offsets, lengths, strides and counts are non-negative integers (glTF 2.0's schema). tinygltf
// read a negative byteOffset as 0, so the data came from the wrong bytes without a word; a
// fraction was truncated the same way. Each is refused, naming the object and the field.
TEST(GltfMalformed, NegativeOrFractionalSizesAreRefused) {
  const fs::path dir = test::scratchDir("m_sizes");
  struct Case {
    const char* array;
    int index;
    const char* field;
    json value;
    const char* expected;
  };
  const Case cases[] = {
      {"accessors", 0, "byteOffset", -4, "accessor 0: byteOffset is -4"},
      {"accessors", 0, "count", -3, "accessor 0: count is -3"},
      {"accessors", 1, "byteOffset", 4.5, "accessor 1: byteOffset is 4.5"},
      {"bufferViews", 1, "byteOffset", -12, "bufferView 1: byteOffset is -12"},
      {"bufferViews", 0, "byteLength", -36, "bufferView 0: byteLength is -36"},
      {"bufferViews", 0, "byteStride", -12, "bufferView 0: byteStride is -12"},
      {"bufferViews", 0, "byteOffset", "0", "bufferView 0: byteOffset is \"0\""},
  };
  int n = 0;
  for (const Case& c : cases) {
    HandGltf g = oneTriangle();
    g.doc[c.array][c.index][c.field] = c.value;
    expectLoadError(g.write(dir, "sizes" + std::to_string(n++)),
                    std::string(c.expected) + ", not a non-negative integer");
  }
  HandGltf buffer = oneTriangle();
  buffer.doc["buffers"] = {{{"byteLength", -1}, {"uri", "buffer_length.bin"}}};
  expectLoadError(buffer.write(dir, "buffer_length"),
                  "buffer 0: byteLength is -1, not a non-negative integer");
  // A whole number written as a float is an integer
  // (GltfReader.WholeFloatsAndPlusSignsAreReadAsMeant).
  HandGltf whole = oneTriangle();
  whole.doc["accessors"][0]["byteOffset"] = 0.0;
  auto loaded = io::loadAsset(whole.write(dir, "whole"));
  EXPECT_TRUE(loaded) << loaded.error().message;
}

// A '%' in a buffer or image uri starts an escape of two hex digits (RFC 3986). tinygltf cut the
// name at a bad one ("File not found : m"); the message names the uri and the escape.
TEST(GltfMalformed, BadPercentEscapeInAUriIsNamed) {
  const fs::path dir = test::scratchDir("m_escape");
  HandGltf g = oneTriangle();
  g.doc["buffers"] = {{{"byteLength", g.bin.size()}, {"uri", "m%zzb.bin"}}};
  expectLoadError(g.write(dir, "escape"),
                  "buffer 0: uri 'm%zzb.bin' has a '%' not followed by two hex digits");
  HandGltf cut = oneTriangle();
  cut.doc["buffers"] = {{{"byteLength", cut.bin.size()}, {"uri", "cut.bin%2"}}};
  expectLoadError(cut.write(dir, "cut"), "buffer 0: uri 'cut.bin%2' has a '%'");
  HandGltf image = texturedTriangle(false);
  image.doc["images"][0]["uri"] = "checker%.png";
  expectLoadError(image.write(dir, "image_escape"),
                  "image 0: uri 'checker%.png' has a '%' not followed by two hex digits");
}

// An accessor without a bufferView (zeros, by the specification) cannot be read: its count is
// bounded by nothing in the file, and 2^40 elements must not be allocated.
TEST(GltfMalformed, AccessorWithoutBufferView) {
  HandGltf g = oneTriangle();
  g.doc["accessors"][0].erase("bufferView");
  g.doc["accessors"][0]["count"] = uint64_t(1) << 40;
  expectLoadError(g.write(test::scratchDir("m"), "noview"), "no bufferView");
}

TEST(GltfMalformed, ByteStrideSmallerThanTheElement) {
  HandGltf g = oneTriangle();
  g.doc["bufferViews"][0]["byteStride"] = 4;  // VEC3 float needs 12
  expectLoadError(g.write(test::scratchDir("m"), "stride"), "byteStride");
}

// tinygltf's own messages for these named neither the object nor its user ("Invalid
// `componentType` in accessor. Got 9999", "'count' property is missing in Accessor."); the file's
// reader checks them first.
TEST(GltfMalformed, BadEnumsStridesAndMissingFieldsNameTheObjectAndItsUser) {
  const fs::path dir = test::scratchDir("m_enums");
  HandGltf component = oneTriangle();
  component.doc["accessors"][0]["componentType"] = 9999;
  expectLoadError(component.write(dir, "component"),
                  "mesh 0, primitive 0, attribute POSITION: accessor 0: componentType 9999 is not "
                  "a glTF component type");
  HandGltf type = oneTriangle();
  type.doc["accessors"][0]["type"] = "VEC7";
  expectLoadError(type.write(dir, "type"),
                  "attribute POSITION: accessor 0: type \"VEC7\" is not a glTF accessor type");
  HandGltf unused = oneTriangle();
  unused.doc["accessors"].push_back(unused.doc["accessors"][0]);
  unused.doc["accessors"][2]["type"] = 3;
  expectLoadError(unused.write(dir, "unused"), ": accessor 2: type 3 is not a glTF accessor type");
  for (int bytes : {2, 13, 300}) {
    HandGltf stride = oneTriangle();
    stride.doc["bufferViews"][0]["byteStride"] = bytes;
    expectLoadError(stride.write(dir, "stride" + std::to_string(bytes)),
                    "bufferView 0 (read by mesh 0, primitive 0, attribute POSITION: accessor 0): "
                    "byteStride " +
                        std::to_string(bytes) + " is not a multiple of 4 from 4 to 252");
  }
  // Required properties tinygltf said were missing "in Accessor" (which one?).
  HandGltf no_count = oneTriangle();
  no_count.doc["accessors"][0].erase("count");
  expectLoadError(no_count.write(dir, "no_count"),
                  "mesh 0, primitive 0, attribute POSITION: accessor 0 has no count (required)");
  HandGltf no_length = oneTriangle();
  no_length.doc["bufferViews"][1].erase("byteLength");
  expectLoadError(no_length.write(dir, "no_length"), "bufferView 1 has no byteLength (required)");
  HandGltf no_buffer_length = oneTriangle();
  no_buffer_length.doc["buffers"] = {{{"uri", "no_buffer_length.bin"}}};
  expectLoadError(no_buffer_length.write(dir, "no_buffer_length"),
                  "buffer 0 has no byteLength (required)");
  // An attribute that is no accessor index was dropped without a word ("no triangles").
  HandGltf named = oneTriangle();
  named.doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = "a";
  expectLoadError(named.write(dir, "named"),
                  "mesh 0, primitive 0, attribute POSITION: \"a\" is not an accessor index");
  HandGltf float_indices = oneTriangle();
  float_indices.doc["accessors"][1]["componentType"] = 5126;
  expectLoadError(float_indices.write(dir, "float_indices"),
                  "mesh 0, primitive 0, indices: accessor 1's componentType 5126 is not one of "
                  "indices' 5121, 5123 or 5125");
}

TEST(GltfMalformed, MissingBinFile) {
  fs::path dir = test::scratchDir("m");
  std::string path = oneTriangle().write(dir, "nobin");
  fs::remove(dir / "nobin.bin");
  expectLoadError(path);
}

// A buffer or image uri that names a folder (tinygltf sized its read buffer with tellg()).
TEST(GltfMalformed, UriNamingAFolder) {
  fs::path dir = test::scratchDir("m");
  fs::create_directories(dir / "sub");
  HandGltf g = oneTriangle();
  g.doc["buffers"] = {{{"byteLength", g.bin.size()}, {"uri", "sub"}}};
  expectLoadError(g.write(dir, "folder_buffer"), "sub");
  fs::create_directories(dir / "checker.png");
  expectLoadError(texturedTriangle(false).write(dir, "folder_image"), "checker.png");
}

// A uri naming a device or a pipe: /dev/zero was read until memory ran out, a pipe waited for a
// writer for ever.
TEST(GltfMalformed, UriNamingADeviceOrAPipe) {
  fs::path dir = test::scratchDir("m");
  HandGltf g = oneTriangle();
  const fs::path device = dir / "zero.bin";  // a link to /dev/zero beside the file
  fs::remove(device);
  fs::create_symlink("/dev/zero", device);
  g.doc["buffers"] = {{{"byteLength", g.bin.size()}, {"uri", "zero.bin"}}};
  expectLoadError(g.write(dir, "device_buffer"), "not a regular file");
  const fs::path pipe = dir / "pipe.bin";
  fs::remove(pipe);
  ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
  g.doc["buffers"] = {{{"byteLength", g.bin.size()}, {"uri", "pipe.bin"}}};
  expectLoadError(g.write(dir, "pipe_buffer"), "not a regular file");
  fs::remove(pipe);
}

TEST(GltfMalformed, MissingTextureImageFile) {
  std::string path = texturedTriangle(false).write(test::scratchDir("m"), "noimage");
  expectLoadError(path, "checker.png");
}

TEST(GltfMalformed, NonFiniteFloatInTheBin) {
  HandGltf g = oneTriangle();
  float nan = std::nanf("");
  std::memcpy(g.bin.data() + 4 * sizeof(float), &nan, sizeof(nan));  // vertex 1, y
  expectLoadError(g.write(test::scratchDir("m"), "nan"), "not a finite number");
}

TEST(GltfMalformed, NodeCycle) {
  HandGltf g = oneTriangle();
  g.doc["nodes"][0]["children"] = {1};
  g.addNode({{"children", {0}}});
  expectLoadError(g.write(test::scratchDir("m"), "cycle"));
}

// glTF requires the node hierarchy to be disjoint trees (each node has at most one parent). Here
// node k lists node k+1 twice, 40 levels deep, with the triangle on the last node: flattening the
// graph as if it were a tree would create 2^39 copies. It must be refused at once.
TEST(GltfMalformed, NodeWithTwoParentsIsRefusedQuickly) {
  HandGltf g = oneTriangle();
  json mesh = g.doc["nodes"][0]["mesh"];
  g.doc["nodes"] = json::array();
  for (int k = 0; k < 40; ++k) g.addNode({{"children", {k + 1, k + 1}}});
  g.addNode({{"mesh", mesh}});
  auto start = std::chrono::steady_clock::now();
  // Depth first, the first node met twice is the last one, listed twice by node 39.
  expectLoadError(g.write(test::scratchDir("m"), "dag"), "node 40");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(GltfMalformed, NegativeMaterialIndex) {
  HandGltf g = oneTriangle();
  g.doc["materials"] = {{{"name", "only"}}};
  g.doc["meshes"][0]["primitives"][0]["material"] = -5;
  expectLoadError(g.write(test::scratchDir("m"), "negative"), "material -5");
}

TEST(GltfMalformed, SceneReferencesAMissingNode) {
  HandGltf g = oneTriangle();
  g.setScene({0, 7});
  expectLoadError(g.write(test::scratchDir("m"), "scene"), "node 7");
}

TEST(GltfMalformed, SparseAccessorIsUnsupported) {
  HandGltf g = oneTriangle();
  int sparse_indices = g.addView(std::vector<uint32_t>{1});
  int sparse_values = g.addView(std::vector<float>{0, 0, 1});
  g.doc["accessors"][0]["sparse"] = {
      {"count", 1},
      {"indices", {{"bufferView", sparse_indices}, {"componentType", kUnsignedInt}}},
      {"values", {{"bufferView", sparse_values}}}};
  expectLoadError(g.write(test::scratchDir("m"), "sparse"), "sparse");
}

TEST(GltfMalformed, EmptyFiles) {
  fs::path dir = test::scratchDir("m");
  writeBytes(dir / "empty.gltf", {});
  writeBytes(dir / "empty.glb", {});
  expectLoadError((dir / "empty.gltf").string());
  expectLoadError((dir / "empty.glb").string());
}

TEST(GltfMalformed, UnknownExtensionAndFolder) {
  fs::path dir = test::scratchDir("m");
  writeBytes(dir / "model.xyz", {'h', 'i'});
  expectLoadError((dir / "model.xyz").string(), "unsupported");
  fs::create_directories(dir / "folder.gltf");
  expectLoadError((dir / "folder.gltf").string(), "folder");
  fs::create_directories(dir / "plainfolder");
  expectLoadError((dir / "plainfolder").string());
  expectLoadError((dir / "does_not_exist.gltf").string(), "not found");
}

// A valid GLB of the quad (12-byte header, JSON chunk, BIN chunk) to corrupt.
std::vector<uint8_t> quadGlb(const fs::path& dir) {
  std::string path = (dir / "quad_source.glb").string();
  EXPECT_TRUE(io::writeGltf(quadAsset(), path));
  return test::readBytes(path);
}

uint32_t read32(const std::vector<uint8_t>& bytes, size_t offset) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

void write32(std::vector<uint8_t>& bytes, size_t offset, uint32_t v) {
  std::memcpy(bytes.data() + offset, &v, 4);
}

// Re-packs a GLB with its JSON chunk edited and its BIN chunk (header included) kept as it was.
template <class Edit>
std::vector<uint8_t> rebuildGlb(const std::vector<uint8_t>& glb, Edit edit) {
  uint32_t json_length = read32(glb, 12);
  json doc = json::parse(glb.begin() + 20, glb.begin() + 20 + json_length);
  edit(doc);
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');
  std::vector<uint8_t> out(glb.begin(), glb.begin() + 12);
  out.resize(20);
  write32(out, 12, uint32_t(text.size()));
  write32(out, 16, 0x4E4F534A);  // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), glb.begin() + 20 + json_length, glb.end());
  write32(out, 8, uint32_t(out.size()));
  return out;
}

TEST(GltfMalformed, GlbBadHeader) {
  fs::path dir = test::scratchDir("m");
  std::vector<uint8_t> good = quadGlb(dir);
  ASSERT_GT(good.size(), 28u);
  ASSERT_TRUE(io::loadAsset((dir / "quad_source.glb").string()));

  std::vector<uint8_t> bytes = good;
  write32(bytes, 8, uint32_t(good.size() + 100));  // total length longer than the file
  writeBytes(dir / "length.glb", bytes);
  expectLoadError((dir / "length.glb").string());

  bytes = good;
  write32(bytes, 16, 0x12345678);  // first chunk is not JSON
  writeBytes(dir / "chunktype.glb", bytes);
  expectLoadError((dir / "chunktype.glb").string());

  bytes = good;
  bytes[0] = 'x';  // not "glTF": read as JSON text, which it is not
  writeBytes(dir / "magic.glb", bytes);
  expectLoadError((dir / "magic.glb").string());

  writeBytes(dir / "short.glb", {'g', 'l', 'T', 'F', 2, 0, 0, 0});
  expectLoadError((dir / "short.glb").string());

  // glTF 1.0's binary layout (version 1) was read as if it were 2 (found by fuzzing).
  bytes = good;
  write32(bytes, 4, 1);
  writeBytes(dir / "version1.glb", bytes);
  expectLoadError((dir / "version1.glb").string(),
                  "GLB version 1 is not supported (glTF 2.0's GLB is version 2)");
}

TEST(GltfMalformed, GlbTruncatedChunk) {
  fs::path dir = test::scratchDir("m");
  std::vector<uint8_t> good = quadGlb(dir);
  // Cut inside the BIN chunk; the header still claims the full length.
  std::vector<uint8_t> bytes(good.begin(), good.end() - 16);
  writeBytes(dir / "cut.glb", bytes);
  expectLoadError((dir / "cut.glb").string());

  // The same cut with the total length patched to match the file: now only the BIN chunk's
  // declared length runs past the end.
  write32(bytes, 8, uint32_t(bytes.size()));
  writeBytes(dir / "cut_patched.glb", bytes);
  expectLoadError((dir / "cut_patched.glb").string());

  // BIN chunk and buffer both 8 bytes longer than the data in the file, while the total length
  // matches the file: only a check that counts the BIN chunk's 8-byte header sees the overrun.
  bytes = rebuildGlb(good, [](json& doc) {
    doc["buffers"][0]["byteLength"] = doc["buffers"][0]["byteLength"].get<size_t>() + 8;
  });
  size_t bin_chunk = 20 + read32(bytes, 12);
  write32(bytes, bin_chunk, read32(bytes, bin_chunk) + 8);
  writeBytes(dir / "chunk_header.glb", bytes);
  expectLoadError((dir / "chunk_header.glb").string());

  // JSON chunk length past the end of the file.
  bytes = good;
  write32(bytes, 12, uint32_t(good.size()));
  writeBytes(dir / "json_len.glb", bytes);
  expectLoadError((dir / "json_len.glb").string());
}

// An embedded image whose bufferView runs past the end of the GLB's binary buffer.
TEST(GltfMalformed, GlbImageBufferViewPastTheEnd) {
  fs::path dir = test::scratchDir("m");
  core::Asset asset = quadAsset();
  asset.mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  core::Texture texture;
  texture.image = {2, 2, std::vector<uint8_t>(16, 200)};
  asset.textures = {texture};
  asset.materials[0].base_color_texture = 0;
  std::string source = (dir / "textured.glb").string();
  ASSERT_TRUE(io::writeGltf(asset, source));
  ASSERT_TRUE(io::loadAsset(source));
  std::vector<uint8_t> out = rebuildGlb(test::readBytes(source), [](json& doc) {
    int image_view = doc["images"][0]["bufferView"];
    doc["bufferViews"][image_view]["byteLength"] = 100000;
  });
  writeBytes(dir / "image_view.glb", out);
  expectLoadError((dir / "image_view.glb").string());
}

}  // namespace
}  // namespace duolod

namespace duolod {
namespace {

// Names that are not UTF-8 (a Latin-1 .mtl, a file named in Latin-1) are written with U+FFFD:
// the JSON writer threw on them, which aborted the process from a function that returns Status.
TEST(GltfWriter, NamesThatAreNotUtf8AreReplacedNotThrownOn) {
  core::Asset asset = quadAsset();
  asset.materials[0].name = "caf\xe9";
  const fs::path dir = test::scratchDir("not_utf8");
  for (const char* name : {"out.gltf", "out.glb"}) {
    const std::string path = (dir / name).string();
    ASSERT_TRUE(io::writeGltf(asset, path)) << name;
    auto back = io::loadAsset(path);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->materials[0].name, "caf\xef\xbf\xbd") << name;  // U+FFFD
  }
  io::LodJsonDocument document;
  document.asset_name = "Avocad\xf6";
  EXPECT_TRUE(test::contains(io::lodJsonText(document), "Avocad\xef\xbf\xbd"));
}

// What an asset's parts say of each other is checked before anything is written: a texture whose
// pixels are fewer than its size says (encoding it read past them: a crash, or heap bytes in the
// file), a material's texture or a submesh's material out of range, a mesh with no triangles.
TEST(GltfWriter, InconsistentAssetsAreRefused) {
  const fs::path dir = test::scratchDir("inconsistent_assets");
  struct Case {
    const char* what;
    std::function<void(core::Asset&)> break_it;
    const char* expected;
  };
  for (const Case& c : std::vector<Case>{
           {"short pixels",
            [](core::Asset& a) { a.textures[0].image.width = a.textures[0].image.height = 2048; },
            "holds 16 bytes"},
           {"texture out of range", [](core::Asset& a) { a.materials[0].base_color_texture = 17; },
            "uses texture 17 of 1"},
           {"material out of range", [](core::Asset& a) { a.mesh.submeshes[0].material = 5; },
            "uses material 5 of 1"},
           {"zero width", [](core::Asset& a) { a.textures[0].image.width = 0; }, "is empty"},
       }) {
    core::Asset asset = texturedQuadAsset();
    c.break_it(asset);
    for (const char* name : {"out.gltf", "out.glb", "out.obj"}) {
      const std::string path = (dir / name).string();
      auto written =
          test::contains(name, ".obj") ? io::writeObj(asset, path) : io::writeGltf(asset, path);
      ASSERT_FALSE(written) << c.what << " " << name;
      EXPECT_TRUE(test::contains(written.error().message, c.expected))
          << c.what << ": " << written.error().message;
    }
    EXPECT_EQ(namesIn(dir), std::vector<std::string>{}) << c.what;
  }
  core::ImageRGBA8 short_image{2048, 2048, std::vector<uint8_t>(16)};
  EXPECT_TRUE(io::encodePng(short_image).empty());
  auto png = io::writePng(short_image, (dir / "short.png").string());
  ASSERT_FALSE(png);
  EXPECT_TRUE(test::contains(png.error().message, "holds 16 bytes")) << png.error().message;

  core::Asset empty = quadAsset();
  empty.mesh.indices.clear();
  empty.mesh.submeshes = {};
  auto nothing = io::writeGltf(empty, (dir / "empty.gltf").string());
  ASSERT_FALSE(nothing);
  EXPECT_TRUE(test::contains(nothing.error().message, "no triangles")) << nothing.error().message;
  EXPECT_EQ(namesIn(dir), std::vector<std::string>{});
}

// A long data: URI is left out of the reader's own checking parse (withoutLongDataUris): the
// checks still hold elsewhere in the document, the data is read as written (with a '/' written
// "\/", as some writers do), a string elsewhere that only looks like a data: URI is left alone,
// and a document that needs rewriting gets its data back.
TEST(GltfReader, LongDataUrisAreReadAsWritten) {
  const fs::path dir = test::scratchDir("long_data_uris");
  auto grid = [] {
    HandGltf g;
    std::vector<float> positions;
    std::vector<uint32_t> indices;
    constexpr uint32_t n = 40;  // 1600 vertices: ~26k characters of base64
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) positions.insert(positions.end(), {float(i), float(j), 0});
    for (uint32_t j = 0; j + 1 < n; ++j)
      for (uint32_t i = 0; i + 1 < n; ++i) {
        const uint32_t a = j * n + i;
        indices.insert(indices.end(), {a, a + 1, a + n + 1, a, a + n + 1, a + n});
      }
    const int p = g.addFloats(positions, "VEC3");
    const int t = g.addIndices(indices, kUnsignedInt);
    // A name that reads like a long data: URI, inside another string (escaped quotes).
    g.addNode({{"mesh", g.addMesh({primitive(p, t)})},
               {"name", "\"data:" + std::string(5000, 'x') + "\""}});
    g.setScene({0});
    return g;
  };
  auto escape_slashes = [](const std::string& path) {
    std::string text = test::readText(path);
    const std::string plain = "data:application/octet-stream",
                      escaped = "data:application\\/octet-stream";
    const size_t at = text.find(plain);
    EXPECT_NE(at, std::string::npos);
    text.replace(at, plain.size(), escaped);
    std::ofstream(path) << text;
  };
  // As written, then with whole floats to rewrite (the rewritten document keeps its data).
  for (const bool rewrite : {false, true}) {
    HandGltf g = grid();
    if (rewrite) {
      g.doc["accessors"][0]["count"] = 1600.0;
      g.doc["nodes"][0]["mesh"] = 0.0;
    }
    const std::string path = g.write(dir, rewrite ? "rewritten" : "embedded", /*embed=*/true);
    escape_slashes(path);
    auto asset = io::loadAsset(path);
    ASSERT_TRUE(asset) << asset.error().message;
    EXPECT_EQ(asset->mesh.triangleCount(), 39u * 39u * 2u);
    ASSERT_EQ(asset->mesh.positions.size(), 1600u);
    EXPECT_EQ(asset->mesh.positions[1599].x, 39.0f);
    EXPECT_EQ(asset->mesh.positions[1599].y, 39.0f);
  }
  {  // a fault inside the data: URI (a raw line break) is the parser's to report, not a check's
    HandGltf g = grid();
    g.doc["bufferViews"][0]["byteOffset"] = -12;
    const std::string path = g.write(dir, "broken", /*embed=*/true);
    std::string text = test::readText(path);
    const size_t at = text.find("base64,");
    ASSERT_NE(at, std::string::npos);
    text.insert(at + 7 + 76, "\n");
    std::ofstream(path) << text;
    auto asset = io::loadAsset(path);
    ASSERT_FALSE(asset);
    EXPECT_FALSE(test::contains(asset.error().message, "byteOffset is -12"))
        << asset.error().message;
  }
  {  // the checks still see the rest of the document
    HandGltf g = grid();
    g.doc["bufferViews"][0]["byteOffset"] = -12;
    const std::string path = g.write(dir, "negative", /*embed=*/true);
    auto asset = io::loadAsset(path);
    ASSERT_FALSE(asset);
    EXPECT_TRUE(test::contains(asset.error().message, "bufferView 0: byteOffset is -12"))
        << asset.error().message;
  }
}

// glTF 2.0's integers may be written as whole floats (36.0, 3.6e1), and a uri's '+' is a plus sign
// (RFC 3986). tinygltf took such integers as absent (a byteOffset of 36.0 read the first triangle
// instead of the second; a count of 3.0 was "not a positive integer") and looked for a+b.bin as
// "a b.bin"; both are read as meant, in .gltf and .glb files.
TEST(GltfReader, WholeFloatsAndPlusSignsAreReadAsMeant) {
  const fs::path dir = test::scratchDir("whole_floats");
  HandGltf g;
  const int view =
      g.addView(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 100, 0, 0, 101, 0, 0, 100, 1, 0});
  const int positions = g.addAccessor(view, kFloat, 3, "VEC3", {{"byteOffset", 36.0}});
  const int indices = g.addIndices(std::vector<uint32_t>{0, 1, 2}, kUnsignedInt);
  g.addNode({{"mesh", g.addMesh({primitive(positions, indices)})}});
  g.setScene({0});
  g.doc["accessors"][positions]["count"] = 3.0;
  g.doc["accessors"][positions]["componentType"] = 5126.0;
  g.doc["accessors"][indices]["bufferView"] = 1.0;
  g.doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 0.0;
  g.doc["meshes"][0]["primitives"][0]["indices"] = 1.0;
  g.doc["nodes"][0]["mesh"] = 0.0;
  g.doc["nodes"][0]["translation"] = {0.0, 2.0, 0.0};  // a float field: whole values read as before
  g.doc["scenes"][0]["nodes"] = {0.0};
  g.doc["scene"] = 0.0;
  g.doc["buffers"] = {{{"byteLength", g.bin.size()}, {"uri", "a+b.bin"}}};
  writeBytes(dir / "a+b.bin", g.bin);
  const std::string path = g.write(dir, "whole");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->mesh.positions.size(), 3u);
  EXPECT_EQ(asset->mesh.positions[0].x, 100.0f);  // the second triangle, from byte 36
  EXPECT_EQ(asset->mesh.positions[1].x, 101.0f);
  EXPECT_EQ(asset->mesh.positions[2].y, 3.0f);  // 1 + the node's translation
  const auto& sources = asset->source_files;
  EXPECT_NE(std::find(sources.begin(), sources.end(), path), sources.end());
  EXPECT_NE(std::find(sources.begin(), sources.end(), (dir / "a+b.bin").string()), sources.end());

  // The same edits in a .glb: its JSON chunk is rewritten, its BIN chunk kept.
  const std::vector<uint8_t> glb = rebuildGlb(quadGlb(dir), [](json& doc) {
    for (json& accessor : doc["accessors"]) {
      accessor["count"] = double(accessor["count"]);
      accessor["componentType"] = double(accessor["componentType"]);
      accessor["bufferView"] = double(accessor["bufferView"]);
    }
    for (json& view : doc["bufferViews"]) view["byteOffset"] = double(view.value("byteOffset", 0));
  });
  writeBytes(dir / "whole.glb", glb);
  auto quad = io::loadAsset((dir / "whole.glb").string());
  ASSERT_TRUE(quad) << quad.error().message;
  EXPECT_EQ(quad->mesh.positions.size(), quadAsset().mesh.positions.size());
  EXPECT_EQ(quad->mesh.triangleCount(), 2u);
  for (size_t v = 0; v < quad->mesh.positions.size(); ++v)
    EXPECT_TRUE(std::find_if(quadAsset().mesh.positions.begin(), quadAsset().mesh.positions.end(),
                             [&](const Vec3& p) {
                               return p.x == quad->mesh.positions[v].x &&
                                      p.y == quad->mesh.positions[v].y &&
                                      p.z == quad->mesh.positions[v].z;
                             }) != quadAsset().mesh.positions.end())
        << "vertex " << v;
}

}  // namespace
}  // namespace duolod
