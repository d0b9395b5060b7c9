#version 450 core
// duolod reference shader "blend" (fragment stage): several textures at different scales blended
// by per-pixel noise, Blinn-Phong lit.
//   layers:   the textures at bindings 0, 1, 3, 4 (base colour, metallic-roughness, occlusion,
//             emissive: whatever the asset has, white where it has none), each read at its own
//             scale, offset and rotation of UV0;
//   weights:  bilinear weights from two channels of a 3-octave 2D value-noise fBm of UV0, so the
//             mix changes per pixel with no texture of its own;
//   normal:   the normal texture at two scales, combined with the "whiteout" blend
//             (Barre-Brisebois & Hill 2012), through the tangent frame;
//   lighting: Blinn-Phong (Blinn 1977) with the usual (n + 8) / 8 normalisation, point light +
//             constant ambient;
//   output:   exposure 1, filmic tone curve (Narkowicz 2015 fit of ACES), sRGB encoding.
// Cost: 6 texture samples plus ~12 arithmetic hashes; many of the samples are of white textures
// on a typical asset, so replacing a sample by the texture's average colour is often exact.

// ---- uniform blocks (INTERFACE.md, std140) ----
layout(std140, binding = 0) uniform Frame {
  mat4 uModel;          // object -> world
  mat4 uView;           // world -> eye
  mat4 uProjection;     // eye -> clip
  mat4 uNormalMatrix;   // inverse-transpose of uModel (upper 3x3 used)
  vec4 uCameraPosition; // world space, w = 1
  vec4 uLightPosition;  // world space point light, w = 1
  vec4 uLightColor;     // rgb radiance scale, w unused; no distance falloff
  vec4 uAmbientColor;   // rgb constant ambient, w unused
  vec4 uObjectInfo;     // xyz bounding-sphere centre (object space), w its radius
};

layout(std140, binding = 1) uniform Material {
  vec4 uBaseColorFactor;  // linear rgba
  vec4 uEmissiveFactor;   // linear rgb, w unused
  vec4 uMaterialParams;   // x metallic, y roughness, z normal scale, w occlusion strength
  vec4 uTextureFlags;     // x baseColor, y metallicRoughness, z normal, w occlusion (1 = present)
  vec4 uTextureFlags2;    // x emissive, yzw unused
};

// ---- textures (INTERFACE.md) ----
layout(binding = 0) uniform sampler2D uBaseColorTexture;         // sRGB data, sampled as linear
layout(binding = 1) uniform sampler2D uMetallicRoughnessTexture; // G roughness, B metallic
layout(binding = 2) uniform sampler2D uNormalTexture;            // tangent-space normal
layout(binding = 3) uniform sampler2D uOcclusionTexture;         // R occlusion (often packed ORM)
layout(binding = 4) uniform sampler2D uEmissiveTexture;          // sRGB data, sampled as linear

// ---- stage inputs ----
layout(location = 0) in vec3 vWorldPosition;
layout(location = 1) in vec3 vWorldNormal;
layout(location = 2) in vec3 vWorldTangent;
layout(location = 3) in vec3 vWorldBitangent;
layout(location = 4) in vec2 vUV0;
layout(location = 5) in vec4 vColor;

layout(location = 0) out vec4 outColor;

// ---- knobs ----
const int NOISE_OCTAVES = 3;              // value-noise octaves (constant trip count)
const float NOISE_SCALE = 5.0;            // noise cells per UV unit, octave 0
const float BLEND_SHARPNESS = 0.18;       // half-width of the weight transition (0.5 = linear)
const float DETAIL_NORMAL_SCALE = 4.1;    // UV scale of the detail normal
const float DETAIL_NORMAL_STRENGTH = 0.6; // detail normal xy relative to the macro normal
const float SPECULAR_DIELECTRIC = 0.25;   // Blinn-Phong specular strength of non-metals
const float EXPOSURE = 1.0;

// Layer placements: uv * scale, rotated, plus offset. Non-integer scales and different angles
// keep the repetitions of the layers from lining up.
const vec2 LAYER1_SCALE = vec2(3.7);
const vec2 LAYER1_OFFSET = vec2(0.13, 0.71);
const float LAYER2_ANGLE = 0.61; // radians
const vec2 LAYER2_SCALE = vec2(7.3);
const vec2 LAYER2_OFFSET = vec2(0.37, 0.05);
const float LAYER3_ANGLE = -1.13;
const vec2 LAYER3_SCALE = vec2(2.3, 1.9);
const vec2 LAYER3_OFFSET = vec2(0.52, 0.29);

// ---- procedural value noise ----

// Integer hash of a 2D lattice point, two independent 32-bit outputs: LCG step, cross-mixing of
// the coordinates and xorshifts (after the pcg2d hash of Jarzynski & Olano 2020).
uvec2 hashCell(ivec2 cell) {
  uvec2 v = uvec2(cell) * 1664525u + 1013904223u;
  v.x += v.y * 1664525u;
  v.y += v.x * 1664525u;
  v ^= v >> 16u;
  v.x += v.y * 1664525u;
  v.y += v.x * 1664525u;
  v ^= v >> 16u;
  return v;
}

// Two random values in [0,1) per lattice point, from the hash's top 24 bits.
vec2 cellValues(ivec2 cell) {
  return vec2(hashCell(cell) >> 8u) * (1.0 / 16777216.0);
}

// 2D value noise, two channels: the lattice values blended bilinearly with a cubic Hermite
// fade (C1), so each channel is smooth and lies in [0,1].
vec2 valueNoise(vec2 p) {
  vec2 cellFloor = floor(p);
  ivec2 cell = ivec2(cellFloor);
  vec2 f = p - cellFloor;
  vec2 w = f * f * (3.0 - 2.0 * f);
  vec2 v00 = cellValues(cell);
  vec2 v10 = cellValues(cell + ivec2(1, 0));
  vec2 v01 = cellValues(cell + ivec2(0, 1));
  vec2 v11 = cellValues(cell + ivec2(1, 1));
  return mix(mix(v00, v10, w.x), mix(v01, v11, w.x), w.y);
}

// fBm of the value noise: each octave doubles the frequency, halves the amplitude and is rotated
// and shifted so the lattices do not align. Normalised back to [0,1].
vec2 noiseFbm(vec2 p) {
  const mat2 octaveRotation = mat2(0.80, 0.60, -0.60, 0.80); // ~36.9 degrees
  vec2 sum = vec2(0.0);
  float amplitude = 0.5;
  float totalAmplitude = 0.0;
  for (int octave = 0; octave < NOISE_OCTAVES; ++octave) {
    sum += amplitude * valueNoise(p);
    totalAmplitude += amplitude;
    p = octaveRotation * p * 2.0 + vec2(11.7, 3.1);
    amplitude *= 0.5;
  }
  return sum / totalAmplitude;
}

// ---- colour helpers ----

vec3 srgbToLinear(vec3 encoded) {
  vec3 low = encoded / 12.92;
  vec3 high = pow((encoded + 0.055) / 1.055, vec3(2.4));
  return mix(high, low, lessThanEqual(encoded, vec3(0.04045)));
}

vec3 linearToSrgb(vec3 linearColor) {
  vec3 low = linearColor * 12.92;
  vec3 high = 1.055 * pow(linearColor, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, lessThanEqual(linearColor, vec3(0.0031308)));
}

vec3 toneMapFilmic(vec3 hdr) {
  vec3 x = hdr * EXPOSURE;
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

// uv rotated by angle, scaled, then offset: a layer's texture coordinates.
vec2 placeLayer(vec2 uv, float angle, vec2 scale, vec2 offset) {
  float c = cos(angle);
  float s = sin(angle);
  return mat2(c, s, -s, c) * uv * scale + offset;
}

void main() {
  vec2 uv = vUV0;

  // --- the four colour layers, each at its own placement ---
  vec3 layer0 = srgbToLinear(texture(uBaseColorTexture, uv).rgb);
  vec4 layer1Sample = texture(uMetallicRoughnessTexture, uv * LAYER1_SCALE + LAYER1_OFFSET);
  vec3 layer1 = layer1Sample.rgb;
  vec3 layer2 = texture(uOcclusionTexture,
                        placeLayer(uv, LAYER2_ANGLE, LAYER2_SCALE, LAYER2_OFFSET)).rgb;
  vec3 layer3 = srgbToLinear(
      texture(uEmissiveTexture, placeLayer(uv, LAYER3_ANGLE, LAYER3_SCALE, LAYER3_OFFSET)).rgb);

  // --- blend weights: two noise channels, sharpened around 0.5, as bilinear weights (they sum
  // to 1 by construction) ---
  vec2 noise = noiseFbm(uv * NOISE_SCALE);
  vec2 s = smoothstep(vec2(0.5 - BLEND_SHARPNESS), vec2(0.5 + BLEND_SHARPNESS), noise);
  vec4 weights = vec4((1.0 - s.x) * (1.0 - s.y), s.x * (1.0 - s.y), (1.0 - s.x) * s.y, s.x * s.y);
  vec3 blended = layer0 * weights.x + layer1 * weights.y + layer2 * weights.z + layer3 * weights.w;
  vec3 albedo = blended * uBaseColorFactor.rgb * vColor.rgb;

  // --- material: roughness and metallic from the metallic-roughness layer and the factors ---
  float roughness = clamp(uMaterialParams.y * layer1Sample.g, 0.0, 1.0);
  float metallic = clamp(uMaterialParams.x * layer1Sample.b, 0.0, 1.0);
  float shininess = exp2(mix(8.0, 3.0, roughness)); // 256 (smooth) .. 8 (rough)
  vec3 specularColor = mix(vec3(SPECULAR_DIELECTRIC), albedo, metallic);
  vec3 diffuseColor = albedo * (1.0 - 0.8 * metallic);

  // --- normal: macro + detail normal map, whiteout blend, through the tangent frame (used
  // unnormalised, as in the pbr shader, so a flat map gives the geometric normal) ---
  vec3 macroNormal = texture(uNormalTexture, uv).xyz * 2.0 - 1.0;
  macroNormal.xy *= uMaterialParams.z;
  vec3 detailNormal =
      texture(uNormalTexture, uv * DETAIL_NORMAL_SCALE + vec2(0.21, 0.63)).xyz * 2.0 - 1.0;
  detailNormal.xy *= uMaterialParams.z * DETAIL_NORMAL_STRENGTH;
  vec3 tangentNormal = vec3(macroNormal.xy + detailNormal.xy, macroNormal.z * detailNormal.z);
  vec3 normal = normalize(tangentNormal.x * vWorldTangent + tangentNormal.y * vWorldBitangent +
                          tangentNormal.z * normalize(vWorldNormal));
  // glTF double-sided materials: back faces are lit with the normal reversed (see pbr.frag).
  normal *= gl_FrontFacing ? 1.0 : -1.0;

  // --- Blinn-Phong: diffuse n.l, specular (n.h)^shininess, normalised by (n + 8) / 8 so the
  // highlight keeps its energy as it narrows; PI folded into the light (see the pbr shader) ---
  vec3 viewDir = normalize(uCameraPosition.xyz - vWorldPosition);
  vec3 lightDir = normalize(uLightPosition.xyz - vWorldPosition);
  vec3 halfDir = normalize(lightDir + viewDir);
  float nDotL = max(dot(normal, lightDir), 0.0);
  float nDotH = max(dot(normal, halfDir), 0.0);
  float specular = (shininess + 8.0) / 8.0 * pow(nDotH, shininess);

  vec3 radiance = uLightColor.rgb * nDotL * (diffuseColor + specularColor * specular) +
                  uAmbientColor.rgb * diffuseColor;

  outColor = vec4(linearToSrgb(toneMapFilmic(radiance)), 1.0);
}
