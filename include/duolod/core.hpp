// duolod core: small math, the Mesh (indexed triangles + attribute streams + submeshes), materials,
// images, errors as values, and logging/progress. Every later stage builds on these types.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace duolod::core {

// ---------------------------------------------------------------------------------------------
// Errors. Bad *input* (files, shaders, flags) is reported as an Error value with a message a user
// can act on (file, field or line, reason). Programmer errors are asserts.

struct Error {
  std::string message;
};

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::move(value)) {}
  Result(Error error) : state_(std::move(error)) {}

  bool ok() const { return std::holds_alternative<T>(state_); }
  explicit operator bool() const { return ok(); }
  T& value() & { return std::get<T>(state_); }
  const T& value() const& { return std::get<T>(state_); }
  T&& value() && { return std::get<T>(std::move(state_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  // On a temporary (`*loadShaderPair("pbr")` passed straight on) the value is moved out, by
  // value: a reference would dangle once the temporary is gone (`const auto& a = *load();`).
  T operator*() && { return std::move(*this).value(); }
  const Error& error() const { return std::get<Error>(state_); }

 private:
  std::variant<T, Error> state_;
};

// Result for functions that return nothing on success.
struct Ok {};
using Status = Result<Ok>;
inline Status okStatus() { return Ok{}; }

// Text without a leading UTF-8 byte-order mark, which some editors (Visual Studio's, for HLSL)
// write and shader compilers take for a stray token.
inline std::string_view withoutByteOrderMark(std::string_view text) {
  return text.starts_with("\xEF\xBB\xBF") ? text.substr(3) : text;
}

// ---------------------------------------------------------------------------------------------
// Math. Plain structs; matrices are column-major like OpenGL's.

struct Vec2 {
  float x = 0, y = 0;
};
struct Vec3 {
  float x = 0, y = 0, z = 0;
  float& operator[](int i) { return (&x)[i]; }
  float operator[](int i) const { return (&x)[i]; }
};
struct Vec4 {
  float x = 0, y = 0, z = 0, w = 0;
};

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(float s, Vec3 a) { return a * s; }
inline Vec3 operator/(Vec3 a, float s) { return {a.x / s, a.y / s, a.z / s}; }
inline Vec3& operator+=(Vec3& a, Vec3 b) { return a = a + b; }
inline bool operator==(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
inline float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(Vec3 a) {
  float len = length(a);
  if (!(len > 0 && len < HUGE_VALF)) {
    // |a|² overflowed (components above ~1.8e19) or underflowed (below ~1e-19): scaled by the
    // largest component first, a finite non-zero vector still has a direction.
    const float largest = std::max({std::abs(a.x), std::abs(a.y), std::abs(a.z)});
    if (!(largest > 0 && largest < HUGE_VALF)) return Vec3{0, 0, 0};
    a = a / largest;
    len = length(a);
  }
  return a / len;
}
inline bool isFinite(Vec3 a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

struct Mat4 {
  std::array<float, 16> m{};  // column-major: m[column * 4 + row]
  float& at(int row, int column) { return m[column * 4 + row]; }
  float at(int row, int column) const { return m[column * 4 + row]; }
  static Mat4 identity();
  static Mat4 translation(Vec3 offset);
};
Mat4 operator*(const Mat4& a, const Mat4& b);
Vec3 transformPoint(const Mat4& m, Vec3 p);   // w = 1, no perspective divide
Vec3 transformVector(const Mat4& m, Vec3 v);  // w = 0
Vec4 transform(const Mat4& m, Vec4 v);
Mat4 inverse(const Mat4& m);  // general 4x4 inverse; returns identity for a singular matrix
Mat4 transpose(const Mat4& m);
Mat4 lookAt(Vec3 eye, Vec3 target, Vec3 up);
Mat4 perspective(float fov_y_radians, float aspect, float z_near, float z_far);

struct Bounds {
  Vec3 min{INFINITY, INFINITY, INFINITY};
  Vec3 max{-INFINITY, -INFINITY, -INFINITY};
  void extend(Vec3 p) {  // inline: it runs per vertex in hot set-up loops
    min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
    max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
  }
  bool empty() const { return min.x > max.x; }
  Vec3 center() const { return (min + max) * 0.5f; }
  Vec3 size() const { return max - min; }
};

struct Sphere {
  Vec3 center;
  float radius = 0;
};

// ---------------------------------------------------------------------------------------------
// Mesh: indexed triangles over flat attribute streams. A stream is either empty (absent) or has
// exactly vertexCount() entries. Submeshes are contiguous index ranges with one material each.

struct Submesh {
  uint32_t first_index = 0;
  uint32_t index_count = 0;
  uint32_t material = 0;
};

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;
  std::vector<Vec4> tangents;  // xyz tangent, w = bitangent sign (+1 or -1), glTF convention
  std::vector<Vec2> uv0;
  std::vector<Vec2> uv1;
  std::vector<Vec4> colors;
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<Submesh> submeshes;

  size_t vertexCount() const { return positions.size(); }
  size_t triangleCount() const { return indices.size() / 3; }
};

// Checks the Mesh invariants (stream sizes, indices in range, finite attributes, submeshes cover
// the index buffer). Returns an Error naming the first problem.
Status validateMesh(const Mesh& mesh);

Bounds computeBounds(const Mesh& mesh);
// Smallest-ish enclosing sphere (Ritter's bounding sphere, refined by one pass).
Sphere computeBoundingSphere(const Mesh& mesh);

// The operations below (normals to vertex reuse) leave a mesh whose streams, indices or
// submeshes are inconsistent (validateMesh's structural checks) as it is, and return 0.
//
// Vertex normals as the angle-weighted average of face normals (Thürmer & Wüthrich 1998), which
// does not depend on how a polygon was triangulated. Vertices at the same position (split by a
// UV or colour seam) get the same normal.
void computeNormals(Mesh& mesh);
// Scales every normal to unit length (a zero one stays zero; one within float rounding of it is
// left as it is); returns how many were more than 1%
// off it. Loaders call it: an OBJ's or PLY's normals need not be unit, and the simplifier's
// attribute quadrics and tangent generation assume they are.
size_t normalizeNormals(Mesh& mesh);
// Per-vertex tangents from UV derivatives in the MikkTSpace convention (tangent along +u, w the
// handedness so that bitangent = w * cross(normal, tangent)), angle-weighted, Gram-Schmidt
// orthogonalized against the normal. Requires normals and uv0 (otherwise does nothing). As
// MikkTSpace, a vertex shared by triangles whose UV mapping keeps the turning sense and by
// mirrored ones (the mirror line of a symmetric layout) is split in two, one per side: the
// mirrored triangles get a copy of it (unless `split_mirrored` is false: the split only matters
// to a normal map, and each copy is a seam the simplifier must keep; see the overload below).
// Returns the number of vertices so added.
size_t computeTangents(Mesh& mesh, bool split_mirrored = true);
// The same, splitting only the mirror-line vertices that the flagged submeshes use (by submesh
// index, as normalMappedSubmeshes gives them; a mesh without submeshes is submesh 0). Every
// triangle's UV orientation counts, so a mirror line on the border between a flagged and another
// submesh is split too, and the mirrored triangles of any submesh move to the copies.
size_t computeTangentsPerSubmesh(Mesh& mesh, const std::vector<bool>& split_submeshes);
// Merges vertices whose every attribute is bitwise equal; returns the number removed.
size_t weldVertices(Mesh& mesh);
// Removes triangles with repeated indices or zero area; returns the number removed.
size_t removeDegenerateTriangles(Mesh& mesh);
// Reorders each submesh's triangles so that a vertex, once shaded, is reused by the triangles
// that follow (Tipsify: Sander, Nehab & Barczak, "Fast triangle reordering for vertex locality
// and reduced overdraw", 2007, with a cache of `cache_size` vertices), then renumbers the
// vertices in order of first use (nearby triangles use nearby vertex ids). The same surface:
// only the order changes. Returns the number of vertex shader runs the order costs in a FIFO
// cache of `cache_size` (before: `before_runs` when given), so callers can see the gain.
size_t optimizeVertexReuse(Mesh& mesh, int cache_size = 16, size_t* before_runs = nullptr);
// Vertex shader runs of the index order in a FIFO post-transform cache of `cache_size` vertices
// (an index out of range counts as a run).
size_t countVertexRuns(std::span<const uint32_t> indices, size_t vertex_count, int cache_size);

// ---------------------------------------------------------------------------------------------
// Images.

struct ImageRGBA8 {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // row-major, top row first, 4 bytes per pixel
};

struct ImageRGBA32F {
  int width = 0, height = 0;
  std::vector<float> pixels;  // row-major, top row first, 4 floats per pixel
};

// ---------------------------------------------------------------------------------------------
// Materials: glTF 2.0 metallic-roughness. Texture indices refer to Asset::textures; -1 = none.

enum class AlphaMode { kOpaque, kMask, kBlend };

struct Material {
  std::string name;
  Vec4 base_color_factor{1, 1, 1, 1};
  float metallic_factor = 1.0f;
  float roughness_factor = 1.0f;
  Vec3 emissive_factor{0, 0, 0};
  float normal_scale = 1.0f;
  float occlusion_strength = 1.0f;
  float alpha_cutoff = 0.5f;
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  bool double_sided = false;
  int base_color_texture = -1;          // sRGB
  int metallic_roughness_texture = -1;  // linear: G roughness, B metallic
  int normal_texture = -1;              // linear, tangent space
  int occlusion_texture = -1;           // linear: R
  int emissive_texture = -1;            // sRGB
};

// The file bytes a texture was decoded from (PNG or JPEG), kept so that writers copy them instead
// of encoding the pixels again: stb's PNG encoder took ~0.5 s per 2048² texture (1.9 s to write
// WaterBottle's .glb) and wrote larger files than the source's. They stand for the texture only
// while its image still fingerprints to `image_fingerprint` (fingerprintImage): code that edits the
// pixels needs no care, the writers then encode the edited image. A texture loaded without
// decoding (io::LoadOptions::decode_textures) has an empty image and is these bytes alone.
struct EncodedImage {
  std::vector<uint8_t> bytes;
  std::string mime_type;           // "image/png" or "image/jpeg"
  int width = 0, height = 0;       // from the file's header
  uint64_t image_fingerprint = 0;  // fingerprintImage of the decoded image (0: not decoded)
};

struct Texture {
  std::string name;  // source file name or glTF image name, for messages
  ImageRGBA8 image;
  bool srgb = false;  // whether the texels are sRGB-encoded colour (set from material usage)
  std::shared_ptr<const EncodedImage> encoded{};  // the source file's bytes, when read from one
};

// A 64-bit fingerprint of an image's size and pixels, eight bytes a step (3.5 ms for 2048²): tells
// whether an image is still the one decoded (EncodedImage), not a cryptographic hash.
uint64_t fingerprintImage(const ImageRGBA8& image);

// An asset: one mesh (all primitives flattened into submeshes), its materials and textures.
struct Asset {
  std::string source_path;
  // Every file it was read from or names (the source, a .gltf's buffers and images, an .obj's
  // .mtl files and textures): the writers never replace one of them (io::refuseSourceFile).
  std::vector<std::string> source_files;
  Mesh mesh;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<std::string> warnings;  // non-fatal problems found while loading
};

// Checks an image's size against its pixels: width and height >= 1 and pixels holding exactly
// width × height × 4 bytes. Returns an Error saying which.
Status validateImage(const ImageRGBA8& image);
// Every submesh's material is below `material_count` (material 0 when there are none: the
// default material). Returns an Error naming the first submesh that is not.
Status validateSubmeshMaterials(const Mesh& mesh, size_t material_count);
// Checks what an asset's parts say of each other (not the mesh: validateMesh): every submesh's
// material and every material's textures are in range (material 0 when there are none: the
// default material), and every texture is a valid image or
// was loaded undecoded (its `encoded` bytes alone). Returns an Error naming the first problem.
Status validateAssetReferences(const Asset& asset);

// Per submesh (by index), whether its material has a normal texture: its tangents then shade,
// and its mirror lines must be split (computeTangents).
std::vector<bool> normalMappedSubmeshes(const Asset& asset);

// ---------------------------------------------------------------------------------------------
// Logging and progress. The CLI installs sinks; the library never writes to stdout itself.

enum class LogLevel { kDebug, kInfo, kWarning, kError };
using LogSink = std::function<void(LogLevel, std::string_view)>;
void setLogSink(LogSink sink);
void setLogLevel(LogLevel minimum);
void log(LogLevel level, std::string_view message);

// ---------------------------------------------------------------------------------------------
// Statistics for measurements and for checking predictions against them.

// Median (the mean of the middle two for an even count); 0 for no values.
double median(std::vector<double> values);
// Ranks 1..n of `values`, ties sharing the mean of the ranks they span ("fractional" ranks).
std::vector<double> fractionalRanks(std::span<const double> values);
// Spearman's rank correlation: Pearson's correlation of the fractional ranks, so ties are handled.
// In [−1, 1]; 0 when either side is constant or the sizes differ or are below 2.
double spearmanCorrelation(std::span<const double> a, std::span<const double> b);

// 64-bit FNV-1a; used to key caches by content.
uint64_t hashBytes(const void* data, size_t size, uint64_t seed = 0xcbf29ce484222325ull);

}  // namespace duolod::core
