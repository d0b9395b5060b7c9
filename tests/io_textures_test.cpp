// Textures read from PNG or JPEG files are written as the bytes they were read from while their
// pixels are unchanged (core::EncodedImage, io::textureFile): no second encoding, which took ~0.5 s
// per 2048² texture with stb's PNG encoder and wrote larger files. An edited texture is encoded
// again from its pixels.
#include <gtest/gtest.h>
#include <stb_image_write.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <nlohmann/json.hpp>

#include "duolod/io.hpp"
#include "duolod/render.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

using test::writeBytes;

void appendTo(void* context, void* data, int size) {
  auto* sink = static_cast<std::vector<uint8_t>*>(context);
  sink->insert(sink->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
}

// An 8×8 RGB gradient: as a 3-channel PNG (io::encodePng writes 4 channels, so these bytes are
// not what encoding the decoded image again gives) and as a JPEG.
std::vector<uint8_t> gradientRgb() {
  std::vector<uint8_t> rgb;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) rgb.insert(rgb.end(), {uint8_t(x * 32), uint8_t(y * 32), 128});
  return rgb;
}
std::vector<uint8_t> rgbPng() {
  std::vector<uint8_t> out, rgb = gradientRgb();
  stbi_write_png_to_func(appendTo, &out, 8, 8, 3, rgb.data(), 8 * 3);
  return out;
}
std::vector<uint8_t> jpeg() {
  std::vector<uint8_t> out, rgb = gradientRgb();
  stbi_write_jpg_to_func(appendTo, &out, 8, 8, 3, rgb.data(), 90);
  return out;
}

// One textured triangle: base colour from rgb.png, emissive from photo.jpg.
std::string writeTexturedGltf(const fs::path& dir) {
  const float positions[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const float uvs[] = {0, 0, 1, 0, 0, 1};
  std::vector<uint8_t> bin(sizeof positions + sizeof uvs);
  std::memcpy(bin.data(), positions, sizeof positions);
  std::memcpy(bin.data() + sizeof positions, uvs, sizeof uvs);
  writeBytes(dir / "tri.bin", bin);
  json doc = {
      {"asset", {{"version", "2.0"}}},
      {"buffers", {{{"uri", "tri.bin"}, {"byteLength", bin.size()}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", sizeof positions}},
        {{"buffer", 0}, {"byteOffset", sizeof positions}, {"byteLength", sizeof uvs}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"},
         {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 3}, {"type", "VEC2"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}}, {"material", 0}}}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"scenes", {{{"nodes", {0}}}}},
      {"scene", 0},
      {"materials",
       {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}},
         {"emissiveTexture", {{"index", 1}}},
         {"emissiveFactor", {1, 1, 1}}}}},
      {"textures", {{{"source", 0}}, {{"source", 1}}}},
      {"images", {{{"uri", "rgb.png"}}, {{"uri", "photo.jpg"}}}},
  };
  std::ofstream(dir / "tri.gltf") << doc.dump();
  return (dir / "tri.gltf").string();
}

TEST(TextureFiles, FingerprintSeesEveryByteAndTheShape) {
  core::ImageRGBA8 a{2, 1, {1, 2, 3, 4, 5, 6, 7, 8}};
  const uint64_t original = core::fingerprintImage(a);
  EXPECT_EQ(core::fingerprintImage(a), original);
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    core::ImageRGBA8 b = a;
    b.pixels[i] ^= 1;
    EXPECT_NE(core::fingerprintImage(b), original) << "byte " << i;
  }
  core::ImageRGBA8 tall{1, 2, a.pixels};  // the same bytes, another shape
  EXPECT_NE(core::fingerprintImage(tall), original);
  core::ImageRGBA8 odd{1, 1, {1, 2, 3, 4}}, odd_longer{1, 1, {1, 2, 3, 4, 0}};  // a tail byte
  EXPECT_NE(core::fingerprintImage(odd), core::fingerprintImage(odd_longer));
}

TEST(TextureFiles, UnchangedTexturesAreWrittenAsTheirSourceBytes) {
  fs::path dir = test::scratchDir("textures");
  const std::vector<uint8_t> png = rgbPng(), jpg = jpeg();
  ASSERT_FALSE(png.empty());
  ASSERT_FALSE(jpg.empty());
  writeBytes(dir / "rgb.png", png);
  writeBytes(dir / "photo.jpg", jpg);
  auto asset = io::loadAsset(writeTexturedGltf(dir));
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->textures.size(), 2u);
  ASSERT_TRUE(asset->textures[0].encoded);
  ASSERT_TRUE(asset->textures[1].encoded);
  EXPECT_EQ(asset->textures[0].encoded->mime_type, "image/png");
  EXPECT_EQ(asset->textures[1].encoded->mime_type, "image/jpeg");
  // The re-encoding the copy replaces really differs from the source (4 channels, stb's PNG).
  ASSERT_NE(io::encodePng(asset->textures[0].image), png);

  fs::path out = test::scratchDir("textures_out");
  // .gltf: the files beside it are the sources' bytes, the JPEG keeps its format.
  ASSERT_TRUE(io::writeGltf(*asset, (out / "a.gltf").string()));
  EXPECT_EQ(test::readBytes(out / "a_texture0.png"), png);
  EXPECT_EQ(test::readBytes(out / "a_texture1.jpg"), jpg);
  EXPECT_FALSE(fs::exists(out / "a_texture1.png"));
  // .glb: the embedded images are the sources' bytes with their MIME types, and decode as before.
  ASSERT_TRUE(io::writeGltf(*asset, (out / "a.glb").string()));
  auto glb = io::loadAsset((out / "a.glb").string());
  ASSERT_TRUE(glb) << glb.error().message;
  ASSERT_EQ(glb->textures.size(), 2u);
  for (size_t t = 0; t < 2; ++t) {
    SCOPED_TRACE(t);
    ASSERT_TRUE(glb->textures[t].encoded);
    EXPECT_EQ(glb->textures[t].encoded->bytes, t == 0 ? png : jpg);
    EXPECT_EQ(glb->textures[t].encoded->mime_type, t == 0 ? "image/png" : "image/jpeg");
    EXPECT_EQ(glb->textures[t].image.pixels, asset->textures[t].image.pixels);
    EXPECT_EQ(glb->textures[t].srgb, asset->textures[t].srgb);
  }
  // .obj: the same files beside the .mtl, which names them.
  ASSERT_TRUE(io::writeObj(*asset, (out / "b.obj").string()));
  EXPECT_EQ(test::readBytes(out / "b_texture0.png"), png);
  EXPECT_EQ(test::readBytes(out / "b_texture1.jpg"), jpg);
  std::ifstream mtl(out / "b.mtl");
  std::string mtl_text{std::istreambuf_iterator<char>(mtl), std::istreambuf_iterator<char>()};
  EXPECT_NE(mtl_text.find("b_texture1.jpg"), std::string::npos) << mtl_text;
  auto obj = io::loadAsset((out / "b.obj").string());
  ASSERT_TRUE(obj) << obj.error().message;
  ASSERT_GE(obj->textures.size(), 1u);
  EXPECT_EQ(obj->textures[0].image.pixels, asset->textures[0].image.pixels);

  // An edited texture is encoded again from its pixels; the other is still copied.
  core::Asset edited = *asset;
  edited.textures[0].image.pixels[0] ^= 0xff;
  ASSERT_TRUE(io::writeGltf(edited, (out / "c.gltf").string()));
  EXPECT_NE(test::readBytes(out / "c_texture0.png"), png);
  auto reread = io::readImage((out / "c_texture0.png").string());
  ASSERT_TRUE(reread) << reread.error().message;
  EXPECT_EQ(reread->pixels, edited.textures[0].image.pixels);
  EXPECT_EQ(test::readBytes(out / "c_texture1.jpg"), jpg);
  // And so is one resized to another shape with the same bytes.
  edited = *asset;
  std::swap(edited.textures[0].image.width, edited.textures[0].image.height);
  edited.textures[0].image.width /= 2;
  edited.textures[0].image.height *= 2;
  EXPECT_FALSE(io::textureFile(edited.textures[0]).copied);
  EXPECT_TRUE(io::textureFile(asset->textures[0]).copied);
}

// Loaded without decoding (LoadOptions::decode_textures = false, what `duolod simplify` does when
// nothing renders): the PNG and JPEG bytes alone, sized by their headers, written back as they
// are; another format is decoded all the same; a PNG whose header is broken is an error naming it.
TEST(TextureFiles, UndecodedTexturesAreSizedAndWrittenBack) {
  fs::path dir = test::scratchDir("undecoded");
  const std::vector<uint8_t> png = rgbPng(), jpg = jpeg();
  writeBytes(dir / "rgb.png", png);
  writeBytes(dir / "photo.jpg", jpg);
  const std::string gltf = writeTexturedGltf(dir);
  auto asset = io::loadAsset(gltf, {.decode_textures = false});
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->textures.size(), 2u);
  for (size_t t = 0; t < 2; ++t) {
    SCOPED_TRACE(t);
    const core::Texture& texture = asset->textures[t];
    EXPECT_TRUE(texture.image.pixels.empty());
    ASSERT_TRUE(texture.encoded);
    EXPECT_EQ(texture.encoded->bytes, t == 0 ? png : jpg);
    EXPECT_EQ(texture.encoded->width, 8);
    EXPECT_EQ(texture.encoded->height, 8);
    EXPECT_TRUE(io::textureFile(texture).copied);
  }
  fs::path out = test::scratchDir("undecoded_out");
  ASSERT_TRUE(io::writeGltf(*asset, (out / "a.gltf").string()));
  EXPECT_EQ(test::readBytes(out / "a_texture0.png"), png);
  EXPECT_EQ(test::readBytes(out / "a_texture1.jpg"), jpg);
  ASSERT_TRUE(io::writeGltf(*asset, (out / "a.glb").string()));
  auto glb = io::loadAsset((out / "a.glb").string());  // decoded: the same pixels as the source's
  auto decoded = io::loadAsset(gltf);
  ASSERT_TRUE(glb) << glb.error().message;
  ASSERT_TRUE(decoded) << decoded.error().message;
  for (size_t t = 0; t < 2; ++t)
    EXPECT_EQ(glb->textures[t].image.pixels, decoded->textures[t].image.pixels) << t;
  ASSERT_TRUE(io::writeObj(*asset, (out / "b.obj").string()));
  EXPECT_EQ(test::readBytes(out / "b_texture0.png"), png);
  EXPECT_EQ(test::readBytes(out / "b_texture1.jpg"), jpg);
  // The OBJ path (MTL textures) keeps them undecoded too.
  auto obj = io::loadAsset((out / "b.obj").string(), {.decode_textures = false});
  ASSERT_TRUE(obj) << obj.error().message;
  ASSERT_GE(obj->textures.size(), 1u);
  EXPECT_TRUE(obj->textures[0].image.pixels.empty());
  ASSERT_TRUE(obj->textures[0].encoded);
  EXPECT_EQ(obj->textures[0].encoded->bytes, png);

  // A BMP is not a glTF image format: decoded, and written as PNG.
  std::vector<uint8_t> bmp, rgb = gradientRgb();
  stbi_write_bmp_to_func(appendTo, &bmp, 8, 8, 3, rgb.data());
  writeBytes(dir / "rgb.png", bmp);  // the uri keeps its name; the bytes decide
  auto with_bmp = io::loadAsset(gltf, {.decode_textures = false});
  ASSERT_TRUE(with_bmp) << with_bmp.error().message;
  EXPECT_EQ(with_bmp->textures[0].image.width, 8);
  EXPECT_EQ(with_bmp->textures[0].image.pixels.size(), 8u * 8 * 4);
  EXPECT_FALSE(with_bmp->textures[0].encoded);
  EXPECT_EQ(io::textureFile(with_bmp->textures[0]).mime_type, "image/png");

  // A PNG signature followed by nothing readable: an error naming the image.
  std::vector<uint8_t> broken(png.begin(), png.begin() + 8);
  broken.resize(40, 0);
  writeBytes(dir / "rgb.png", broken);
  auto refused = io::loadAsset(gltf, {.decode_textures = false});
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("rgb.png"), std::string::npos) << refused.error().message;
  EXPECT_NE(refused.error().message.find("PNG header"), std::string::npos)
      << refused.error().message;
}

// Undecoded loading checks a PNG's chunk CRCs and decodes a JPEG (no checksum) to check it; a
// damaged file is decoded after all, so it is refused (or accepted) as in a decoded load, never
// copied through unread.
TEST(TextureFiles, DamagedUndecodedTexturesAreDecodedToBeJudged) {
  fs::path dir = test::scratchDir("undecoded_damaged");
  const std::vector<uint8_t> png = rgbPng(), jpg = jpeg();
  const std::string gltf = writeTexturedGltf(dir);
  writeBytes(dir / "photo.jpg", jpg);
  const auto load = [&](const std::vector<uint8_t>& rgb, const std::vector<uint8_t>& photo) {
    writeBytes(dir / "rgb.png", rgb);
    writeBytes(dir / "photo.jpg", photo);
    return io::loadAsset(gltf, {.decode_textures = false});
  };
  {  // intact: both kept undecoded
    auto asset = load(png, jpg);
    ASSERT_TRUE(asset) << asset.error().message;
    EXPECT_TRUE(asset->textures[0].image.pixels.empty());
    EXPECT_TRUE(asset->textures[1].image.pixels.empty());
  }
  // The PNG cut inside its image data: a decoded load refuses it, and so does this one.
  std::vector<uint8_t> cut(png.begin(), png.end() - 20);
  writeBytes(dir / "rgb.png", cut);
  auto refused_decoded = io::loadAsset(gltf);
  auto refused = load(cut, jpg);
  ASSERT_FALSE(refused_decoded);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("rgb.png"), std::string::npos) << refused.error().message;
  // A wrong CRC on the header chunk only: stb reads the pixels all the same, so the texture is
  // accepted decoded, as a decoded load would.
  std::vector<uint8_t> bad_crc = png;
  bad_crc[8 + 8 + 13] ^= 0x5a;  // IHDR's CRC
  auto decoded_instead = load(bad_crc, jpg);
  ASSERT_TRUE(decoded_instead) << decoded_instead.error().message;
  EXPECT_EQ(decoded_instead->textures[0].image.width, 8);
  EXPECT_EQ(decoded_instead->textures[0].image.pixels.size(), 8u * 8 * 4);
  // Random damage and cuts never read outside the bytes (run under ASan) and, when the check
  // passes, leave a file stb still reads the size of.
  std::mt19937 random(7);
  for (int trial = 0; trial < 400; ++trial) {
    std::vector<uint8_t> bytes = trial % 2 ? png : jpg;
    const size_t flips = random() % 4;
    for (size_t f = 0; f < flips; ++f) bytes[random() % bytes.size()] = uint8_t(random());
    if (trial % 3 == 0) bytes.resize(random() % bytes.size() + 1);
    auto kept = io::keepUndecoded(bytes, "damaged");
    if (kept && *kept) {
      EXPECT_GT((*kept)->width, 0);
    }
  }
  // Well-formed but of a kind stb does not read: an unknown critical PNG chunk (right CRC) after
  // IHDR, a JPEG with an empty JPG0 (0xF0) segment before its scan (after the frame header, which
  // is as far as the header read goes). Decoded to be judged, and refused.
  std::vector<uint8_t> unknown_chunk(png.begin(), png.begin() + 33);  // signature + IHDR
  const uint8_t abcd[] = {0, 0, 0, 0, 'A', 'B', 'C', 'D', 0xdb, 0x17, 0x20, 0xa5};  // CRC("ABCD")
  unknown_chunk.insert(unknown_chunk.end(), std::begin(abcd), std::end(abcd));
  unknown_chunk.insert(unknown_chunk.end(), png.begin() + 33, png.end());
  EXPECT_FALSE(load(unknown_chunk, jpg));
  std::vector<uint8_t> extension = jpg;
  const uint8_t sos[] = {0xff, 0xda};
  auto scan = std::search(extension.begin(), extension.end(), std::begin(sos), std::end(sos));
  ASSERT_NE(scan, extension.end());
  extension.insert(scan, {0xff, 0xf0, 0x00, 0x02});
  EXPECT_FALSE(load(png, extension));
  // A JPEG cut before its end (no EOI): decoded to be judged, and stb refuses it.
  std::vector<uint8_t> cut_jpeg(jpg.begin(), jpg.end() - 2);
  ASSERT_FALSE(load(png, cut_jpeg));
  EXPECT_NE(load(png, cut_jpeg).error().message.find("photo.jpg"), std::string::npos)
      << load(png, cut_jpeg).error().message;
  // One byte of the scan data changed (never to a marker) in a busier 48x48 photo: the segments
  // stay whole, so only decoding can tell. Every change stb refuses is refused (with decodeImage's
  // message), the others are kept undecoded. Some of each must occur.
  std::vector<uint8_t> busy_rgb, busy;
  for (int i = 0; i < 48 * 48 * 3; ++i) busy_rgb.push_back(uint8_t((i * 37) ^ (i / 144 * 91)));
  stbi_write_jpg_to_func(appendTo, &busy, 48, 48, 3, busy_rgb.data(), 90);
  const std::vector<uint8_t>& photo = busy;
  const size_t scan_start = size_t(
      std::search(photo.begin(), photo.end(), std::begin(sos), std::end(sos)) - photo.begin());
  ASSERT_LT(scan_start + 4, photo.size());
  const size_t scan_data = scan_start + 2 + (size_t(photo[scan_start + 2]) << 8 | photo[scan_start + 3]);
  ASSERT_LT(scan_data + 16, photo.size());
  size_t refused_by_stb = 0, kept_undecoded = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<uint8_t> bytes = photo;
    const size_t at = scan_data + random() % (photo.size() - 2 - scan_data);
    if (bytes[at] == 0xff || (at > 0 && bytes[at - 1] == 0xff)) continue;  // a marker or stuffing
    bytes[at] = uint8_t(bytes[at] ^ (1 + random() % 0xfe));
    if (bytes[at] == 0xff) continue;
    auto kept = io::keepUndecoded(bytes, "scan.jpg");
    if (!io::decodeImage(bytes, "scan.jpg")) {
      ++refused_by_stb;
      // The segments are whole, so it is refused at once, as a decoded load would.
      ASSERT_FALSE(kept) << "byte " << at << ": stb refuses it, yet it was not refused";
      EXPECT_NE(kept.error().message.find("scan.jpg: cannot decode image"), std::string::npos)
          << kept.error().message;
    } else {
      ASSERT_TRUE(kept) << kept.error().message;
      if (*kept) ++kept_undecoded;
    }
  }
  EXPECT_GT(refused_by_stb, 0u);
  EXPECT_GT(kept_undecoded, 0u);
}

// One image used by two textures (colour and emission) is written once, in .gltf, .glb and
// .obj; a texture whose pixels were edited gets its own file.
TEST(TextureFiles, AnImageSharedByTexturesIsWrittenOnce) {
  fs::path dir = test::scratchDir("shared_image");
  const std::vector<uint8_t> png = rgbPng();
  writeBytes(dir / "rgb.png", png);
  writeBytes(dir / "photo.jpg", jpeg());
  const std::string gltf = writeTexturedGltf(dir);
  json doc = json::parse(std::ifstream(gltf));
  doc["textures"][1]["source"] = 0;
  std::ofstream(gltf) << doc.dump();
  for (bool decode : {true, false}) {
    SCOPED_TRACE(decode ? "decoded" : "undecoded");
    auto asset = io::loadAsset(gltf, {.decode_textures = decode});
    ASSERT_TRUE(asset) << asset.error().message;
    ASSERT_EQ(asset->textures.size(), 2u);
    fs::path out = test::scratchDir(decode ? "shared_image_out" : "shared_image_out_undecoded");
    ASSERT_TRUE(io::writeGltf(*asset, (out / "a.gltf").string()));
    json written = json::parse(std::ifstream(out / "a.gltf"));
    EXPECT_EQ(written["images"].size(), 1u);
    ASSERT_EQ(written["textures"].size(), 2u);
    EXPECT_EQ(written["textures"][0]["source"], 0);
    EXPECT_EQ(written["textures"][1]["source"], 0);
    EXPECT_EQ(test::readBytes(out / "a_texture0.png"), png);
    EXPECT_FALSE(fs::exists(out / "a_texture1.png"));
    ASSERT_TRUE(io::writeGltf(*asset, (out / "a.glb").string()));
    auto glb = io::loadAsset((out / "a.glb").string());
    ASSERT_TRUE(glb) << glb.error().message;
    ASSERT_EQ(glb->textures.size(), 2u);
    EXPECT_EQ(glb->textures[0].image.pixels, glb->textures[1].image.pixels);
    const std::vector<uint8_t> glb_bytes = test::readBytes(out / "a.glb");  // glTF 2.0 §4.4
    ASSERT_GT(glb_bytes.size(), 20u);
    uint32_t json_length = 0;
    std::memcpy(&json_length, glb_bytes.data() + 12, 4);
    ASSERT_LE(20 + size_t(json_length), glb_bytes.size());
    json glb_json = json::parse(glb_bytes.begin() + 20, glb_bytes.begin() + 20 + json_length);
    EXPECT_EQ(glb_json["images"].size(), 1u);
    EXPECT_EQ(glb_json["textures"][1]["source"], 0);
    ASSERT_TRUE(io::writeObj(*asset, (out / "b.obj").string()));
    EXPECT_EQ(test::readBytes(out / "b_texture0.png"), png);
    EXPECT_FALSE(fs::exists(out / "b_texture1.png"));
    std::ifstream mtl(out / "b.mtl");
    const std::string mtl_text((std::istreambuf_iterator<char>(mtl)), {});
    EXPECT_NE(mtl_text.find("map_Kd b_texture0.png"), std::string::npos) << mtl_text;
    EXPECT_NE(mtl_text.find("map_Ke b_texture0.png"), std::string::npos) << mtl_text;
  }
  // An edited copy is its own image.
  auto asset = io::loadAsset(gltf);
  ASSERT_TRUE(asset) << asset.error().message;
  asset->textures[1].image.pixels[0] ^= 0xff;
  fs::path out = test::scratchDir("shared_image_edited");
  ASSERT_TRUE(io::writeGltf(*asset, (out / "a.gltf").string()));
  json written = json::parse(std::ifstream(out / "a.gltf"));
  EXPECT_EQ(written["images"].size(), 2u);
  EXPECT_EQ(written["textures"][1]["source"], 1);
  EXPECT_EQ(test::readBytes(out / "a_texture0.png"), png);
  EXPECT_TRUE(fs::exists(out / "a_texture1.png"));
  // .obj files are numbered as written: textures 0 and 1 share one file, an edited third copy
  // is the second file, not _texture2.
  auto three = io::loadAsset(gltf);
  ASSERT_TRUE(three) << three.error().message;
  three->textures.push_back(three->textures[0]);
  three->textures[2].image.pixels[0] ^= 0xff;
  ASSERT_TRUE(io::writeObj(*three, (out / "b.obj").string()));
  EXPECT_EQ(test::readBytes(out / "b_texture0.png"), png);
  EXPECT_TRUE(fs::exists(out / "b_texture1.png"));
  EXPECT_FALSE(fs::exists(out / "b_texture2.png"));
}

// An undecoded texture cannot be drawn: the renderer says so instead of drawing it untextured.
TEST(TextureFiles, RendererRefusesUndecodedTextures) {
  fs::path dir = test::scratchDir("undecoded_render");
  writeBytes(dir / "rgb.png", rgbPng());
  writeBytes(dir / "photo.jpg", jpeg());
  const std::string gltf = writeTexturedGltf(dir);
  auto undecoded = io::loadAsset(gltf, {.decode_textures = false});
  auto decoded = io::loadAsset(gltf);
  ASSERT_TRUE(undecoded) << undecoded.error().message;
  ASSERT_TRUE(decoded) << decoded.error().message;
  auto renderer = render::Renderer::create();
  ASSERT_TRUE(renderer) << renderer.error().message;
  auto refused = (*renderer)->uploadAsset(*undecoded);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("without decoding"), std::string::npos)
      << refused.error().message;
  EXPECT_TRUE((*renderer)->uploadAsset(*decoded));
}

// A file the asset was read from is never replaced, also where it carries the name an output's
// texture gets; an earlier output beside the source is (writing the same output twice works).
TEST(TextureFiles, OutputTexturesDoNotReplaceTheSources) {
  fs::path dir = test::scratchDir("texture_clash");
  const std::vector<uint8_t> png = rgbPng(), jpg = jpeg();
  writeBytes(dir / "rgb.png", png);
  writeBytes(dir / "photo.jpg", jpg);
  auto asset = io::loadAsset(writeTexturedGltf(dir));
  ASSERT_TRUE(asset) << asset.error().message;
  // The images are source files even when textures are not loaded (nothing read them).
  auto bare = io::loadAsset(writeTexturedGltf(dir), {.load_textures = false});
  ASSERT_TRUE(bare) << bare.error().message;
  for (const char* image : {"rgb.png", "photo.jpg"})
    EXPECT_FALSE(io::refuseSourceFile(*bare, (dir / image).string())) << image;
  EXPECT_FALSE(io::refuseSourceFile(*bare, (dir / "tri.bin").string()));
  EXPECT_TRUE(io::refuseSourceFile(*bare, (dir / "out.gltf").string()));
  for (int run = 0; run < 2; ++run) {  // beside the source, twice: the second replaces the first
    SCOPED_TRACE(run);
    auto gltf = io::writeGltf(*asset, (dir / "out.gltf").string());
    EXPECT_TRUE(gltf) << gltf.error().message;
    auto obj = io::writeObj(*asset, (dir / "out.obj").string());
    EXPECT_TRUE(obj) << obj.error().message;
  }
  // An OBJ whose texture file is named first_texture0.png, written as first.obj beside itself.
  writeBytes(dir / "first_texture0.png", png);
  std::ofstream(dir / "lib.mtl") << "newmtl m\nmap_Kd first_texture0.png\n";
  std::ofstream(dir / "src.obj") << "mtllib lib.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
  for (bool decode : {true, false}) {
    SCOPED_TRACE(decode);
    auto source = io::loadAsset((dir / "src.obj").string(), {.decode_textures = decode});
    ASSERT_TRUE(source) << source.error().message;
    ASSERT_EQ(source->textures.size(), 1u);
    core::Asset edited = *source;
    if (decode) edited.textures[0].image.pixels[0] ^= 0xff;
    for (const char* output : {"first.obj", "first.gltf"}) {
      auto refused = output == std::string("first.obj")
                         ? io::writeObj(edited, (dir / output).string())
                         : io::writeGltf(edited, (dir / output).string());
      ASSERT_FALSE(refused) << output;
      EXPECT_NE(refused.error().message.find("first_texture0.png: is a file the asset was read from"),
                std::string::npos)
          << refused.error().message;
      EXPECT_EQ(test::readBytes(dir / "first_texture0.png"), png);
    }
    // Nor the .mtl it was read from (lib.mtl), nor the .obj itself.
    EXPECT_FALSE(io::writeObj(edited, (dir / "lib.obj").string()));
    EXPECT_FALSE(io::writeObj(edited, (dir / "." / "src.obj").string()));
    fs::path elsewhere = test::scratchDir("texture_clash_out");
    EXPECT_TRUE(io::writeObj(edited, (elsewhere / "first.obj").string()));
  }
}

// The real asset: WaterBottle's four 2048² PNGs come out byte for byte, in a .glb no larger than
// the sources (stb's encoder made it 12.3 MB from 8.8 MB of PNGs).
TEST(TextureFiles, WaterBottleTexturesAreCopied) {
  DUOLOD_REQUIRE_ASSET(source, "gltf/WaterBottle/WaterBottle.gltf");
  auto asset = io::loadAsset(source);
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->textures.size(), 4u);
  std::vector<std::vector<uint8_t>> sources;
  size_t source_bytes = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(source).parent_path()))
    if (entry.path().extension() == ".png") {
      sources.push_back(test::readBytes(entry.path()));
      source_bytes += sources.back().size();
    }
  ASSERT_EQ(sources.size(), 4u);
  fs::path out = test::scratchDir("bottle_textures");
  ASSERT_TRUE(io::writeGltf(*asset, (out / "bottle.gltf").string()));
  for (int t = 0; t < 4; ++t) {
    std::vector<uint8_t> written =
        test::readBytes(out / ("bottle_texture" + std::to_string(t) + ".png"));
    EXPECT_NE(std::find(sources.begin(), sources.end(), written), sources.end())
        << "bottle_texture" << t << ".png is not one of the source PNGs";
  }
  ASSERT_TRUE(io::writeGltf(*asset, (out / "bottle.glb").string()));
  EXPECT_LT(fs::file_size(out / "bottle.glb"), source_bytes + 400 * 1024);
  // Real files pass the undecoded load's chunk check (none is decoded after all).
  auto undecoded = io::loadAsset(source, {.decode_textures = false});
  ASSERT_TRUE(undecoded) << undecoded.error().message;
  for (const core::Texture& texture : undecoded->textures) {
    EXPECT_TRUE(texture.image.pixels.empty()) << texture.name;
    EXPECT_TRUE(texture.encoded) << texture.name;
  }
}

}  // namespace
}  // namespace duolod
