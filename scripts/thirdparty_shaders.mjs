// Extracts two third-party PBR shaders into plain GLSL 450 core files for duolod's shader round-trip
// test (tests/shader_roundtrip_test.cpp):
//   three.js MeshPhysicalMaterial (npm `three`): ShaderLib/meshphysical.glsl.js with every
//     `#include <chunk>` expanded from ShaderChunk/*.glsl.js, light counts substituted and
//     `#pragma unroll_loop` loops unrolled the way three's WebGLProgram does, and the prefix three
//     generates at run time (built-in uniforms/attributes, GLSL 3 macros, tone mapping and output
//     encoding functions) written out for one configuration;
//   glTF Sample Viewer PBR (npm `@khronosgroup/gltf-viewer`): primitive.vert and pbr.frag taken from
//     the bundled JS strings, their `#include <x.glsl>` expanded, with the defines the viewer sets for
//     a textured metallic-roughness material with one punctual light.
// The result keeps the shaders' own names; locations and bindings are left to glslang's
// auto-mapping (CompileOptions::auto_map_locations), since neither source declares any.
// *_duolod.{vert,frag} are the same shaders adapted onto duolod's renderer interface
// (shaders/INTERFACE.md) so the round-trip test can render them.
//
// usage: node scripts/thirdparty_shaders.mjs NPM_CACHE_DIR   (writes NPM_CACHE_DIR/extracted/*)
import { mkdirSync, readFileSync, writeFileSync, renameSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';

const cache = process.argv[2];
if (!cache) {
  console.error('usage: node thirdparty_shaders.mjs NPM_CACHE_DIR');
  process.exit(2);
}
const out = join(cache, 'extracted');
mkdirSync(out, { recursive: true });

// SPIR-V has no bool uniforms (OpTypeBool cannot be externally visible): an int stands in, and a
// macro keeps every use of the name reading a bool.
function boolUniformsToInt(text) {
  return text.replace(/^([ \t]*)uniform bool (\w+);/gm,
    (match, indent, name) => `${indent}uniform int ${name}Flag;\n${indent}#define ${name} (${name}Flag != 0)`);
}

function writeAtomic(name, text) {
  text = boolUniformsToInt(text);
  const path = join(out, name);
  writeFileSync(path + '.tmp', text);
  renameSync(path + '.tmp', path);
  console.log(`thirdparty_shaders: wrote ${path} (${text.split('\n').length} lines)`);
}

function expandIncludes(text, lookup, pattern, stack = []) {
  return text.replace(pattern, (match, name) => {
    const chunk = lookup(name);
    if (chunk === undefined) throw new Error(`cannot resolve #include <${name}> (from ${stack.join(' > ') || 'main'})`);
    if (stack.includes(name)) throw new Error(`recursive #include <${name}>`);
    return expandIncludes(chunk, lookup, pattern, [...stack, name]);
  });
}

// ---- three.js MeshPhysicalMaterial --------------------------------------------------------------

async function threePhysical() {
  const shaders = join(cache, 'three', 'package', 'src', 'renderers', 'shaders');
  const { ShaderChunk } = await import(pathToFileURL(join(shaders, 'ShaderChunk.js')).href);
  const physical = await import(pathToFileURL(join(shaders, 'ShaderLib', 'meshphysical.glsl.js')).href);
  const includePattern = /^[ \t]*#include +<([\w\d./]+)>/gm;  // three's WebGLProgram pattern
  // One directional and one point light, nothing else (three's replaceLightNums).
  const lights = {
    NUM_SUN_LIGHTS: 0, NUM_DIR_LIGHTS: 1, NUM_SPOT_LIGHTS: 0, NUM_SPOT_LIGHT_MAPS: 0,
    NUM_SPOT_LIGHT_COORDS: 0, NUM_RECT_AREA_LIGHTS: 0, NUM_POINT_LIGHTS: 1, NUM_HEMI_LIGHTS: 0,
    NUM_SUN_LIGHT_SHADOWS: 0, NUM_DIR_LIGHT_SHADOWS: 0, NUM_SPOT_LIGHT_SHADOWS_WITH_MAPS: 0,
    NUM_SPOT_LIGHT_SHADOWS: 0, NUM_POINT_LIGHT_SHADOWS: 0, NUM_LIGHT_PROBE_GRIDS: 0,
    NUM_CLIPPING_PLANES: 0, UNION_CLIPPING_PLANES: 0,
  };
  const unrollPattern = /#pragma unroll_loop_start\s+for\s*\(\s*int\s+i\s*=\s*(\d+)\s*;\s*i\s*<\s*(\d+)\s*;\s*i\s*\+\+\s*\)\s*{([\s\S]+?)}\s+#pragma unroll_loop_end/g;
  function prepare(text) {
    text = expandIncludes(text, (name) => ShaderChunk[name], includePattern);
    // Longest names first so NUM_SPOT_LIGHT_SHADOWS_WITH_MAPS is not cut by NUM_SPOT_LIGHT_SHADOWS.
    for (const name of Object.keys(lights).sort((a, b) => b.length - a.length))
      text = text.replace(new RegExp(name, 'g'), String(lights[name]));
    return text.replace(unrollPattern, (match, start, end, body) => {
      let unrolled = '';
      for (let i = parseInt(start); i < parseInt(end); i++)
        unrolled += body.replace(/\[\s*i\s*\]/g, `[ ${i} ]`).replace(/UNROLLED_LOOP_INDEX/g, String(i));
      return unrolled;
    });
  }
  // The material features this configuration exercises (three's prefix defines): textures for
  // colour, normal (tangent space), roughness, metalness, emissive, ambient occlusion; clearcoat
  // and sheen; ACES tone mapping; sRGB output.
  const features = [
    '#define PHYSICAL', '#define USE_MAP', '#define MAP_UV uv', '#define USE_NORMALMAP',
    '#define USE_NORMALMAP_TANGENTSPACE', '#define NORMALMAP_UV uv', '#define USE_ROUGHNESSMAP',
    '#define ROUGHNESSMAP_UV uv', '#define USE_METALNESSMAP', '#define METALNESSMAP_UV uv',
    '#define USE_EMISSIVEMAP', '#define EMISSIVEMAP_UV uv', '#define USE_AOMAP', '#define AOMAP_UV uv',
    '#define USE_CLEARCOAT', '#define USE_SHEEN', '#define USE_UV',
  ];
  const vertexPrefix = [
    '#version 450 core', '#define SHADER_TYPE MeshPhysicalMaterial', '#define SHADER_NAME MeshPhysicalMaterial',
    ...features, '#define attribute in', '#define varying out', '#define texture2D texture',
    'uniform mat4 modelMatrix;', 'uniform mat4 modelViewMatrix;', 'uniform mat4 projectionMatrix;',
    'uniform mat4 viewMatrix;', 'uniform mat3 normalMatrix;', 'uniform vec3 cameraPosition;',
    'uniform bool isOrthographic;', 'in vec3 position;', 'in vec3 normal;', 'in vec2 uv;', '',
  ].join('\n');
  const fragmentPrefix = [
    '#version 450 core', '#define SHADER_TYPE MeshPhysicalMaterial', '#define SHADER_NAME MeshPhysicalMaterial',
    ...features, '#define varying in', 'layout(location = 0) out highp vec4 pc_fragColor;',
    '#define gl_FragColor pc_fragColor', '#define texture2D texture', '#define textureCube texture',
    '#define TONE_MAPPING', 'uniform mat4 viewMatrix;', 'uniform vec3 cameraPosition;',
    'uniform bool isOrthographic;', '',
  ].join('\n');
  // three appends these after its tone-mapping and colour-space chunks (WebGLProgram).
  const fragmentFunctions = [
    'vec3 toneMapping( vec3 color ) { return ACESFilmicToneMapping( color ); }',
    'vec4 linearToOutputTexel( vec4 value ) { return sRGBTransferOETF( value ); }',
    'float luminance( const in vec3 rgb ) { const vec3 weights = vec3( 0.2126, 0.7152, 0.0722 ); return dot( weights, rgb ); }',
    '',
  ].join('\n');
  const fragmentChunks = expandIncludes('#include <tonemapping_pars_fragment>\n#include <colorspace_pars_fragment>\n',
    (name) => ShaderChunk[name], includePattern);
  const vertex = vertexPrefix + prepare(physical.vertex);
  const fragment = fragmentPrefix + fragmentChunks + fragmentFunctions + prepare(physical.fragment);
  writeAtomic('three_physical.vert', vertex);
  writeAtomic('three_physical.frag', fragment);
  writeAtomic('three_physical_duolod.vert', adaptThreeVertex(boolUniformsToInt(vertex)));
  writeAtomic('three_physical_duolod.frag', adaptThreeFragment(boolUniformsToInt(fragment)));
}

// three's built-in uniforms and material parameters as expressions of duolod's blocks; its light
// arrays as duolod's one light (directional, towards the light from the object's centre, in view
// space as three expects; the point light switched off); its textures at duolod's bindings; every
// UV transform the identity (three's default).
function adaptThreeVertex(text) {
  text = withDuolodInterface(text);
  const expressions = {
    modelMatrix: 'uModel', modelViewMatrix: 'uView * uModel', projectionMatrix: 'uProjection', viewMatrix: 'uView',
    normalMatrix: 'mat3(uView) * mat3(uNormalMatrix)', cameraPosition: 'uCameraPosition.xyz',
  };
  // The UV transforms of the enabled maps (the others sit in inactive #ifdef blocks).
  for (const map of ['map', 'normalMap', 'roughnessMap', 'metalnessMap', 'emissiveMap', 'aoMap'])
    expressions[`${map}Transform`] = 'mat3(1.0)';
  text = uniformsToGlobals(text, expressions);
  const attributes = [['in vec3 position', 0], ['in vec3 normal', 1], ['in vec2 uv', 3]];
  for (const [declaration, location] of attributes) text = qualify(text, declaration, `layout(location = ${location})`);
  return text;
}

function adaptThreeFragment(text) {
  text = withDuolodInterface(text);
  const expressions = {
    viewMatrix: 'uView', cameraPosition: 'uCameraPosition.xyz', toneMappingExposure: '1.0',
    diffuse: 'uBaseColorFactor.rgb', opacity: 'uBaseColorFactor.a', emissive: 'uEmissiveFactor.rgb',
    metalness: 'uMaterialParams.x', roughness: 'uMaterialParams.y', normalScale: 'vec2(uMaterialParams.z)',
    aoMapIntensity: 'uMaterialParams.w', ior: '1.5', specularIntensity: '1.0', specularColor: 'vec3(1.0)',
    ambientLightColor: 'uAmbientColor.rgb',
  };
  text = uniformsToGlobals(text, expressions);
  const samplers = [['map', 0], ['roughnessMap', 1], ['metalnessMap', 1], ['normalMap', 2], ['aoMap', 3],
    ['emissiveMap', 4]];
  for (const [name, binding] of samplers) text = qualify(text, `uniform sampler2D ${name}`, `layout(binding = ${binding})`);
  text = replaceOnce(text, /uniform\s+DirectionalLight\s+directionalLights\s*\[\s*1\s*\]\s*;/, `
DirectionalLight duolodDirectionalLight() {
  vec3 center = (uModel * vec4(uObjectInfo.xyz, 1.0)).xyz;
  return DirectionalLight(normalize(mat3(uView) * (uLightPosition.xyz - center)), uLightColor.rgb);
}
#define directionalLights DirectionalLight[1](duolodDirectionalLight())
`);
  return replaceOnce(text, /uniform\s+PointLight\s+pointLights\s*\[\s*1\s*\]\s*;/,
    '\n#define pointLights PointLight[1](PointLight(vec3(0.0), vec3(0.0), 0.0, 1.0))\n');
}

function replaceOnce(text, pattern, replacement) {
  if (!pattern.test(text)) throw new Error(`adapter: ${pattern} not found`);
  return text.replace(pattern, replacement);
}

function withDuolodInterface(text) {
  return text.replace(/^#version 450 core\n/, '#version 450 core\n' + duolodInterface);
}

// ---- glTF Sample Viewer ------------------------------------------------------------------------

function gltfViewer() {
  const bundle = readFileSync(join(cache, 'gltf-viewer', 'package', 'dist', 'gltf-viewer.module.js'), 'utf8');
  // `var NAME = "...";` string literals, read as JavaScript (JSON cannot read every JS escape).
  const strings = {};
  for (const match of bundle.matchAll(/^var (\w+) = ("(?:[^"\\\n]|\\.)*");/gm))
    strings[match[1]] = Function(`"use strict"; return (${match[2]});`)();
  // The viewer's `shaderSources.set("file", variable)` table maps include names to those strings.
  const sources = {};
  for (const match of bundle.matchAll(/shaderSources\.set\("([\w.]+)",\s*(\w+)\)/g)) sources[match[1]] = strings[match[2]];
  for (const needed of ['primitive.vert', 'pbr.frag'])
    if (sources[needed] === undefined) throw new Error(`gltf-viewer bundle: ${needed} not found`);
  const includePattern = /^[ \t]*#include <([\w\d./]+)>/gm;
  // The defines the viewer sets for a primitive with normals, tangents and UVs and a textured
  // metallic-roughness material, opaque, with one punctual light and KHR_materials_emissive_strength.
  const defines = [
    '#define HAS_NORMAL_VEC3 1', '#define HAS_TANGENT_VEC4 1', '#define HAS_TEXCOORD_0_VEC2 1',
    '#define MATERIAL_METALLICROUGHNESS 1', '#define HAS_BASE_COLOR_MAP 1', '#define HAS_NORMAL_MAP 1',
    '#define HAS_METALLIC_ROUGHNESS_MAP 1', '#define HAS_OCCLUSION_MAP 1', '#define HAS_EMISSIVE_MAP 1',
    '#define MATERIAL_EMISSIVE_STRENGTH 1', '#define ALPHAMODE_OPAQUE 0', '#define ALPHAMODE_MASK 1',
    '#define ALPHAMODE_BLEND 2', '#define ALPHAMODE ALPHAMODE_OPAQUE', '#define USE_PUNCTUAL 1',
    '#define LIGHT_COUNT 1', '#define TONEMAP_KHR_PBR_NEUTRAL 1', '#define LINEAR_OUTPUT 0', '',
  ].join('\n');
  const expand = (name) => expandIncludes(sources[name], (include) => sources[include], includePattern);
  const fragment = expand('pbr.frag');
  // The viewer numbers its debug views and sets DEBUG to DEBUG_NONE for normal rendering.
  const debugNames = [...new Set(fragment.match(/\bDEBUG_\w+/g) || [])].filter((name) => name !== 'DEBUG_NONE').sort();
  const debugDefines = ['#define DEBUG_NONE 0', ...debugNames.map((name, i) => `#define ${name} ${i + 1}`),
    '#define DEBUG DEBUG_NONE', ''].join('\n');
  const vertex = expand('primitive.vert');
  writeAtomic('gltf_viewer_pbr.vert', '#version 450 core\n' + defines + vertex);
  writeAtomic('gltf_viewer_pbr.frag', '#version 450 core\n' + defines + debugDefines + fragment);
  writeAtomic('gltf_viewer_pbr_duolod.vert', withDuolodInterface('#version 450 core\n' + defines + adaptVertex(vertex)));
  writeAtomic('gltf_viewer_pbr_duolod.frag',
              withDuolodInterface('#version 450 core\n' + defines + debugDefines + adaptFragment(fragment)));
}

// ---- adapters onto duolod's renderer interface (shaders/INTERFACE.md) --------------------------
// The viewer's uniforms become expressions of duolod's Frame/Material blocks, its attributes and
// textures get duolod's locations and bindings, and its light array becomes duolod's one light
// (directional, from the light position towards the object's centre: the interface has no
// distance falloff, the viewer's point lights do). Uniforms the interface lacks keep their
// declarations and read 0, the GL default (uv set 0, no transform).

const duolodInterface = `layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(std140, binding = 1) uniform Material {
  vec4 uBaseColorFactor; vec4 uEmissiveFactor; vec4 uMaterialParams; vec4 uTextureFlags; vec4 uTextureFlags2;
};
`;

// `uniform T name;` → a global `T name;` assigned `expression` first thing in main() (a macro
// would also rewrite parameters that share the name, as three's `viewMatrix` arguments do).
function uniformsToGlobals(text, expressions) {
  const assignments = [];
  for (const [name, expression] of Object.entries(expressions)) {
    const pattern = new RegExp(`uniform\\s+(\\w+)\\s+${name}\\s*;`);
    const match = text.match(pattern);
    if (!match) throw new Error(`adapter: no uniform ${name}`);
    text = text.replace(pattern, `${match[1]} ${name};`);
    assignments.push(`${name} = ${expression};`);
  }
  return replaceOnce(text, /void\s+main\s*\(\s*(void)?\s*\)\s*{/, (header) => `${header}\n  ${assignments.join('\n  ')}\n`);
}

function qualify(text, declaration, qualifier) {
  const pattern = new RegExp(`(^|[;\\s])(${declaration.replace(/ /g, '\\s+')}\\s*;)`, 'm');
  if (!pattern.test(text)) throw new Error(`adapter: no declaration ${declaration}`);
  return text.replace(pattern, `$1${qualifier} $2`);
}

function adaptVertex(text) {
  text = uniformsToGlobals(text, {
    u_ViewProjectionMatrix: 'uProjection * uView', u_ModelMatrix: 'uModel', u_NormalMatrix: 'uNormalMatrix',
  });
  const attributes = [['in vec3 a_position', 0], ['in vec3 a_normal', 1], ['in vec4 a_tangent', 2],
    ['in vec2 a_texcoord_0', 3]];
  for (const [declaration, location] of attributes) text = qualify(text, declaration, `layout(location = ${location})`);
  return text;
}

function adaptFragment(text) {
  const expressions = {
    u_Camera: 'uCameraPosition.xyz', u_BaseColorFactor: 'uBaseColorFactor', u_EmissiveFactor: 'uEmissiveFactor.rgb',
    u_MetallicFactor: 'uMaterialParams.x', u_RoughnessFactor: 'uMaterialParams.y', u_NormalScale: 'uMaterialParams.z',
    u_OcclusionStrength: 'uMaterialParams.w', u_EmissiveStrength: '1.0', u_Exposure: '1.0',
  };
  text = uniformsToGlobals(text, expressions);
  const samplers = [['u_BaseColorSampler', 0], ['u_MetallicRoughnessSampler', 1], ['u_NormalSampler', 2],
    ['u_OcclusionSampler', 3], ['u_EmissiveSampler', 4]];
  for (const [name, binding] of samplers) text = qualify(text, `uniform sampler2D ${name}`, `layout(binding = ${binding})`);
  text = qualify(text, 'out vec4 g_finalColor', 'layout(location = 0)');
  const lights = /uniform\s+Light\s+u_Lights\s*\[\s*LIGHT_COUNT\s*\+\s*1\s*\]\s*;/;
  return replaceOnce(text, lights, `
Light duolodLight() {
  vec3 center = (uModel * vec4(uObjectInfo.xyz, 1.0)).xyz;
  return Light(normalize(center - uLightPosition.xyz), -1.0, uLightColor.rgb, 1.0, uLightPosition.xyz, 0.0, 0.0,
               LightType_Directional);
}
#define u_Lights Light[LIGHT_COUNT + 1](duolodLight(), duolodLight())
`);
}

await threePhysical();
gltfViewer();
