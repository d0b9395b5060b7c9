// The GLSL/HLSL front end: every stage compiles to SPIR-V that validates for OpenGL 4.5 with names
// kept; #include resolves through the including file's folder and include_dirs; #defines apply;
// malformed input gives an error naming the file and line, never a crash.
#include <gtest/gtest.h>

#include <fstream>

#include "duolod/shader.hpp"
#include "shader/ir.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

void writeFile(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::vector<uint32_t> expectCompiles(const std::string& source, Stage stage, const std::string& name,
                                     const CompileOptions& options = {}) {
  auto words = compileToSpirv(source, stage, name, options);
  EXPECT_TRUE(words.ok()) << (words.ok() ? "" : words.error().message);
  if (!words.ok()) return {};
  auto valid = validateSpirv(*words, name);
  EXPECT_TRUE(valid.ok()) << (valid.ok() ? "" : valid.error().message);
  return *words;
}

std::string expectError(const std::string& source, Stage stage, const std::string& name,
                        const CompileOptions& options = {}) {
  auto words = compileToSpirv(source, stage, name, options);
  EXPECT_FALSE(words.ok()) << name << " compiled but should not have";
  return words.ok() ? std::string() : words.error().message;
}

bool hasName(const std::vector<uint32_t>& words, const std::string& name) {
  auto module = ir::parseModule(words);
  if (!module.ok()) return false;
  for (const ir::Instruction& instruction : module->names)
    if (instruction.opcode == spv::OpName && instruction.literalString(1) == name) return true;
  return false;
}

const char* kTessControl = R"(#version 450 core
layout(vertices = 3) out;
layout(location = 0) in vec3 vPosition[];
layout(location = 0) out vec3 tcPosition[];
void main() {
  tcPosition[gl_InvocationID] = vPosition[gl_InvocationID];
  if (gl_InvocationID == 0) {
    gl_TessLevelInner[0] = 4.0;
    gl_TessLevelOuter[0] = 4.0;
    gl_TessLevelOuter[1] = 4.0;
    gl_TessLevelOuter[2] = 4.0;
  }
}
)";

const char* kTessEvaluation = R"(#version 450 core
layout(triangles, equal_spacing, ccw) in;
layout(location = 0) in vec3 tcPosition[];
void main() {
  vec3 p = gl_TessCoord.x * tcPosition[0] + gl_TessCoord.y * tcPosition[1] +
           gl_TessCoord.z * tcPosition[2];
  gl_Position = vec4(p, 1.0);
}
)";

TEST(ShaderFrontend, TessellationStagesCompileAndValidate) {
  std::vector<uint32_t> control = expectCompiles(kTessControl, Stage::kTessControl, "patch.tesc");
  std::vector<uint32_t> evaluation = expectCompiles(kTessEvaluation, Stage::kTessEvaluation, "patch.tese");
  auto control_module = ir::parseModule(control);
  auto evaluation_module = ir::parseModule(evaluation);
  ASSERT_TRUE(control_module.ok() && evaluation_module.ok());
  EXPECT_NE(control_module->entryFunction(spv::ExecutionModelTessellationControl), nullptr);
  EXPECT_NE(evaluation_module->entryFunction(spv::ExecutionModelTessellationEvaluation), nullptr);
  EXPECT_TRUE(hasName(control, "tcPosition"));
}

const char* kHlslPixel = R"(
cbuffer Material : register(b1) {
  float4 uBaseColorFactor;
};
Texture2D uBaseColorTexture : register(t0);
SamplerState uBaseColorSampler : register(s0);
struct PixelInput {
  float4 position : SV_Position;
  float2 uv : TEXCOORD0;
};
float4 PSMain(PixelInput input) : SV_Target0 {
  return uBaseColorTexture.Sample(uBaseColorSampler, input.uv) * uBaseColorFactor;
}
)";

const char* kHlslVertex = R"(
cbuffer Frame : register(b0) {
  float4x4 uModelViewProjection;
};
struct VertexOutput {
  float4 position : SV_Position;
  float2 uv : TEXCOORD0;
};
VertexOutput VSMain(float3 position : POSITION, float2 uv : TEXCOORD0) {
  VertexOutput output;
  output.position = mul(uModelViewProjection, float4(position, 1.0));
  output.uv = uv;
  return output;
}
)";

TEST(ShaderFrontend, HlslVertexAndPixelShadersCompile) {
  CompileOptions options;
  options.language = Language::kHlsl;
  options.entry_point = "PSMain";
  std::vector<uint32_t> pixel = expectCompiles(kHlslPixel, Stage::kFragment, "material.hlsl", options);
  EXPECT_TRUE(hasName(pixel, "uBaseColorTexture"));
  options.entry_point = "VSMain";
  expectCompiles(kHlslVertex, Stage::kVertex, "frame.hlsl", options);
  // A wrong entry point is an error naming it.
  options.entry_point = "Missing";
  std::string message = expectError(kHlslVertex, Stage::kVertex, "frame.hlsl", options);
  EXPECT_TRUE(test::contains(message, "Missing")) << message;
}

TEST(ShaderFrontend, DefinesApply) {
  const char* source = R"(#version 450 core
layout(location = 0) out vec4 outColor;
void main() {
#if USE_RED
  outColor = vec4(RED_LEVEL, 0.0, 0.0, 1.0);
#else
  outColor = vec4(0.0, 0.0, 1.0, 1.0);
#endif
}
)";
  CompileOptions options;
  options.defines = {{"USE_RED", "1"}, {"RED_LEVEL", "0.25"}};
  std::vector<uint32_t> red = expectCompiles(source, Stage::kFragment, "define.frag", options);
  options.defines = {{"USE_RED", "0"}};
  std::vector<uint32_t> blue = expectCompiles(source, Stage::kFragment, "define.frag", options);
  EXPECT_NE(red, blue);
  // 0.25 appears as a float constant only in the red variant.
  auto has_quarter = [](const std::vector<uint32_t>& words) {
    auto module = ir::parseModule(words);
    ir::DefUse uses(*module);
    for (const ir::Instruction& instruction : module->types_values)
      if (ir::constantFloatValue(uses, instruction.result_id) == 0.25f) return true;
    return false;
  };
  EXPECT_TRUE(has_quarter(red));
  EXPECT_FALSE(has_quarter(blue));
  // A define used without a value is an error naming the file and line.
  options.defines = {{"USE_RED", "1"}};
  std::string message = expectError(source, Stage::kFragment, "define.frag", options);
  EXPECT_TRUE(test::contains(message, "define.frag:5")) << message;
}

TEST(ShaderFrontend, IncludesResolveThroughFolderAndIncludeDirs) {
  std::filesystem::path dir = test::scratchDir("shader_frontend_include");
  writeFile(dir / "library" / "lighting.glsl",
            "float lambert(vec3 n, vec3 l) { return max(dot(n, l), 0.0); }\n");
  writeFile(dir / "local" / "sub" / "tint.glsl", "const vec3 TINT = vec3(0.5, 0.75, 1.0);\n");
  const char* source = R"(#version 450 core
#extension GL_GOOGLE_include_directive : require
#include "sub/tint.glsl"
#include <lighting.glsl>
layout(location = 0) in vec3 vNormal;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(TINT * lambert(normalize(vNormal), vec3(0, 0, 1)), 1.0); }
)";
  std::string main_path = (dir / "local" / "main.frag").string();
  CompileOptions options;
  options.include_dirs = {(dir / "library").string()};
  std::vector<uint32_t> words = expectCompiles(source, Stage::kFragment, main_path, options);
  EXPECT_TRUE(hasName(words, "lambert(vf3;vf3;"));

  // Without the include dir, the error names the missing file and where it was included.
  std::string message = expectError(source, Stage::kFragment, main_path, {});
  EXPECT_TRUE(test::contains(message, "lighting.glsl")) << message;
  EXPECT_TRUE(test::contains(message, main_path + ":4")) << message;

  // An error inside an included file names that file and its line.
  writeFile(dir / "library" / "broken.glsl", "float f() {\n  return undefinedThing;\n}\n");
  const char* includes_broken = R"(#version 450 core
#extension GL_GOOGLE_include_directive : require
#include <broken.glsl>
void main() {}
)";
  message = expectError(includes_broken, Stage::kFragment, main_path, options);
  EXPECT_TRUE(test::contains(message, "broken.glsl:2")) << message;
  EXPECT_TRUE(test::contains(message, "undefinedThing")) << message;
}

TEST(ShaderFrontend, IncludesWorkWithoutTheExtensionLine) {
  // Users write `#include` as in C; the front end enables GL_GOOGLE_include_directive itself.
  std::filesystem::path dir = test::scratchDir("shader_frontend_include_plain");
  writeFile(dir / "color.glsl", "const vec4 COLOR = vec4(1.0);\n");
  const char* source = R"(#version 450 core
#include "color.glsl"
layout(location = 0) out vec4 outColor;
void main() { outColor = COLOR; }
)";
  expectCompiles(source, Stage::kFragment, (dir / "main.frag").string());
}

TEST(ShaderFrontend, MalformedShadersGiveFileAndLine) {
  std::string message = expectError("#version 450 core\nvoid main() {\n  float x = ;\n}\n", Stage::kFragment,
                                    "syntax.frag");
  EXPECT_TRUE(test::contains(message, "syntax.frag:3")) << message;

  message = expectError("#version 450 core\nvoid main() { undeclared = 1.0; }\n", Stage::kVertex,
                        "undeclared.vert");
  EXPECT_TRUE(test::contains(message, "undeclared.vert:2")) << message;
  EXPECT_TRUE(test::contains(message, "undeclared")) << message;

  // No main: a link error, still naming the file.
  message = expectError("#version 450 core\nvoid notMain() {}\n", Stage::kFragment, "nomain.frag");
  EXPECT_TRUE(test::contains(message, "nomain.frag")) << message;

  // Garbage, empty input, an unterminated comment, binary bytes, a missing #version: errors, not
  // crashes.
  std::string binary("\x00\x01\xff\xfe#version 450\n", 17);
  for (const std::string& source :
       {std::string(), std::string("}}}}"), std::string("#version 450 core\n/* never closed"), binary,
        std::string("#version 9999\nvoid main(){}\n"),
        std::string("#version 450 core\nvoid main() { for(;;) { int a[-1]; } }\n")}) {
    auto words = compileToSpirv(source, Stage::kFragment, "garbage.frag");
    EXPECT_FALSE(words.ok());
    if (!words.ok()) {
      EXPECT_TRUE(test::contains(words.error().message, "garbage.frag")) << words.error().message;
    }
  }
  // Malformed HLSL too.
  CompileOptions hlsl;
  hlsl.language = Language::kHlsl;
  message = expectError("float4 main() : SV_Target0 { return float4(1, 2); \n", Stage::kFragment, "broken.hlsl", hlsl);
  EXPECT_TRUE(test::contains(message, "broken.hlsl")) << message;
}

// A file that includes itself (directly or around a cycle) is an error naming it; glslang alone
// expanded it until memory ran out.
TEST(ShaderFrontend, RecursiveIncludesAreAnError) {
  std::filesystem::path dir = test::scratchDir("shader_frontend_include_cycle");
  writeFile(dir / "self.glsl", "#include \"self.glsl\"\nfloat f() { return 1.0; }\n");
  writeFile(dir / "a.glsl", "#include \"b.glsl\"\n");
  writeFile(dir / "b.glsl", "#include \"a.glsl\"\n");
  for (const char* first : {"self.glsl", "a.glsl"}) {
    const std::string source =
        std::string("#version 450 core\n#include \"") + first +
        "\"\nlayout(location = 0) out vec4 c;\nvoid main() { c = vec4(1.0); }\n";
    const std::string message =
        expectError(source.c_str(), Stage::kFragment, (dir / "main.frag").string(), {});
    EXPECT_TRUE(test::contains(message, "nested more than")) << message;
  }
}

// A vertex stage that never writes the position draws nothing: refused, naming the file, on the
// SPIR-V path too (`shader` and `generate` compile the user's stages here; only the renderer's
// GLSL path checked it). A pixel shader given as the vertex stage is the usual cause.
TEST(ShaderFrontend, AVertexStageWithoutThePositionIsRefused) {
  const char* no_position =
      "#version 450 core\nlayout(location = 0) in vec3 p;\n"
      "layout(location = 0) out vec3 v;\nvoid main() { v = p; }\n";
  std::string message = expectError(no_position, Stage::kVertex, "nopos.vert", {});
  EXPECT_TRUE(test::contains(message, "nopos.vert: the vertex stage never writes gl_Position"))
      << message;
  // Only the vertex stage needs it, and one that writes it through gl_PerVertex compiles.
  expectCompiles(no_position, Stage::kFragment, "nopos.frag", {});
  expectCompiles("#version 450 core\nvoid main() { gl_Position = vec4(0.0); }\n", Stage::kVertex,
                 "ok.vert", {});
  CompileOptions options;
  options.language = Language::kHlsl;
  options.entry_point = "PSMain";
  message = expectError(kHlslPixel, Stage::kVertex, "material.hlsl", options);
  EXPECT_TRUE(test::contains(message, "material.hlsl: the vertex stage never writes SV_Position"))
      << message;
}

// A UTF-8 byte-order mark before the source, or before an included file, is not a token.
TEST(ShaderFrontend, AByteOrderMarkIsSkipped) {
  std::filesystem::path dir = test::scratchDir("shader_frontend_bom");
  writeFile(dir / "common.glsl",
            "\xEF\xBB\xBF"
            "float half_of(float x) { return 0.5 * x; }\n");
  const std::string source = std::string("\xEF\xBB\xBF") +
                             "#version 450 core\n#include \"common.glsl\"\n"
                             "layout(location = 0) out vec4 c;\n"
                             "void main() { c = vec4(half_of(1.0)); }\n";
  expectCompiles(source.c_str(), Stage::kFragment, (dir / "main.frag").string(), {});
}

TEST(ShaderFrontend, ValidatorRejectsBrokenModules) {
  std::vector<uint32_t> words =
      expectCompiles("#version 450 core\nlayout(location=0) out vec4 c;\nvoid main() { c = vec4(1.0); }\n",
                     Stage::kFragment, "ok.frag");
  ASSERT_FALSE(words.empty());
  std::vector<uint32_t> truncated(words.begin(), words.end() - 3);
  auto status = validateSpirv(truncated, "truncated.spv");
  EXPECT_FALSE(status.ok());
  if (!status.ok()) {
    EXPECT_TRUE(test::contains(status.error().message, "truncated.spv")) << status.error().message;
  }
  // SPIRV-Cross gets only valid modules: corrupt ones (every single word flipped in turn, a file
  // damaged on disk) are errors, never a crash inside its parser.
  int refused = 0;
  for (size_t i = 5; i < words.size(); ++i) {
    std::vector<uint32_t> damaged = words;
    damaged[i] ^= 0x00ff00ffu;
    for (Target target : {Target::kGlsl450, Target::kGlslEs300, Target::kHlsl50})
      if (!crossCompile(damaged, target, "damaged.spv").ok()) ++refused;
  }
  EXPECT_GT(refused, 0);
}

// HLSL output semantics: the given ones by location; an input at another location gets the first
// TEXCOORD<k> no input has (SPIRV-Cross's own TEXCOORD<location> gave location 1 the TEXCOORD1
// of the uv1 stream at location 4).
TEST(ShaderFrontend, HlslVertexSemanticsNeverRepeat) {
  auto words = compileToSpirv(R"(#version 450
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec4 inExtra;
layout(location = 3) in vec2 inUV0;
layout(location = 4) in vec2 inUV1;
void main() { gl_Position = vec4(inPosition + inExtra.xyz, 1.0) + vec4(inUV0, inUV1); }
)",
                              Stage::kVertex, "semantics.vert");
  ASSERT_TRUE(words.ok()) << words.error().message;
  auto hlsl = crossCompile(*words, Target::kHlsl50, "semantics.vert",
                           {{0, "POSITION0"}, {3, "TEXCOORD0"}, {4, "TEXCOORD1"}});
  ASSERT_TRUE(hlsl.ok()) << hlsl.error().message;
  for (const char* expected : {"inPosition : POSITION0;", "inExtra : TEXCOORD2;",
                               "inUV0 : TEXCOORD0;", "inUV1 : TEXCOORD1;"})
    EXPECT_NE(hlsl->find(expected), std::string::npos) << expected << "\n" << *hlsl;
  EXPECT_TRUE(
      checkCrossCompiled(*hlsl, Target::kHlsl50, Stage::kVertex, "semantics.vert.hlsl").ok());
}

}  // namespace
}  // namespace duolod::shader
