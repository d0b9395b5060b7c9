#version 450 core
// duolod reference shader "pbr" (fragment stage): glTF 2.0 metallic-roughness forward shading.
//   specular: Cook-Torrance microfacet BRDF with the GGX normal distribution (Walter et al. 2007),
//             the height-correlated Smith visibility term (Heitz 2014) and Schlick's Fresnel
//             approximation (Schlick 1994);
//   diffuse:  Lambert, weighted by (1 - F) as in the glTF specification's reference BRDF;
//   ambient:  constant uAmbientColor on the diffuse colour plus an analytic split-sum
//             environment-BRDF fit (Karis 2014) as a crude ambient specular, both occluded;
//   output:   exposure 1, filmic tone curve (Narkowicz 2015 fit of ACES), sRGB encoding.
// Every texture is always sampled: a texture the material lacks is bound to white (normal map:
// flat), which makes the multiplication a no-op. The uTextureFlags stay in the block only so
// the block layout matches INTERFACE.md.

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
layout(binding = 3) uniform sampler2D uOcclusionTexture;         // R occlusion
layout(binding = 4) uniform sampler2D uEmissiveTexture;          // sRGB data, sampled as linear

// ---- stage inputs ----
layout(location = 0) in vec3 vWorldPosition;
layout(location = 1) in vec3 vWorldNormal;
layout(location = 2) in vec3 vWorldTangent;
layout(location = 3) in vec3 vWorldBitangent;
layout(location = 4) in vec2 vUV0;
layout(location = 5) in vec4 vColor;

layout(location = 0) out vec4 outColor;

const float PI = 3.14159265358979;
const float DIELECTRIC_F0 = 0.04;     // glTF: reflectance of every dielectric at normal incidence
const float MIN_ROUGHNESS = 0.045;    // keeps the GGX lobe from degenerating into a spike
const float EXPOSURE = 1.0;

// sRGB transfer function (IEC 61966-2-1), decoding: the textures are stored sRGB-encoded but the
// renderer samples them as plain linear data.
vec3 srgbToLinear(vec3 encoded) {
  vec3 low = encoded / 12.92;
  vec3 high = pow((encoded + 0.055) / 1.055, vec3(2.4));
  return mix(high, low, lessThanEqual(encoded, vec3(0.04045)));
}

// sRGB transfer function, encoding, on a display-referred value in [0,1].
vec3 linearToSrgb(vec3 linearColor) {
  vec3 low = linearColor * 12.92;
  vec3 high = 1.055 * pow(linearColor, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, lessThanEqual(linearColor, vec3(0.0031308)));
}

// Filmic tone curve: Narkowicz's rational fit of the ACES reference rendering transform.
vec3 toneMapFilmic(vec3 hdr) {
  vec3 x = hdr * EXPOSURE;
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

// GGX / Trowbridge-Reitz normal distribution (Walter et al. 2007); alpha = roughness^2.
float distributionGgx(float nDotH, float alpha) {
  float alpha2 = alpha * alpha;
  float denom = nDotH * nDotH * (alpha2 - 1.0) + 1.0;
  return alpha2 / (PI * denom * denom);
}

// Height-correlated Smith masking-shadowing for GGX (Heitz 2014), already divided by the
// Cook-Torrance denominator 4 (n.l)(n.v): V = G2 / (4 n.l n.v).
float visibilitySmithHeightCorrelated(float nDotL, float nDotV, float alpha) {
  float alpha2 = alpha * alpha;
  float lambdaV = nDotL * sqrt(nDotV * nDotV * (1.0 - alpha2) + alpha2);
  float lambdaL = nDotV * sqrt(nDotL * nDotL * (1.0 - alpha2) + alpha2);
  return 0.5 / max(lambdaV + lambdaL, 1e-6);
}

// Schlick's approximation of the Fresnel reflectance (Schlick 1994).
vec3 fresnelSchlick(vec3 f0, float cosTheta) {
  float m = clamp(1.0 - cosTheta, 0.0, 1.0);
  float m2 = m * m;
  return f0 + (vec3(1.0) - f0) * (m2 * m2 * m);
}

// Analytic fit of the pre-integrated split-sum environment BRDF (Karis 2014, "Physically Based
// Shading on Mobile"): scale and bias on F0 for a uniform environment. Crude, but it gives the
// ambient term a view-dependent specular part that brightens at grazing angles.
vec3 ambientSpecularBrdf(vec3 f0, float perceptualRoughness, float nDotV) {
  const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
  const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
  vec4 r = perceptualRoughness * c0 + c1;
  float a004 = min(r.x * r.x, exp2(-9.28 * nDotV)) * r.x + r.y;
  vec2 scaleBias = vec2(-1.04, 1.04) * a004 + r.zw;
  return f0 * scaleBias.x + scaleBias.y;
}

void main() {
  vec2 uv = vUV0;

  // --- material inputs (glTF 2.0 §3.9) ---
  // Base colour: texture (sRGB) x factor x vertex colour, all linear after decoding.
  vec4 baseColorSample = texture(uBaseColorTexture, uv);
  vec3 baseColor = srgbToLinear(baseColorSample.rgb) * uBaseColorFactor.rgb * vColor.rgb;

  // Metallic-roughness: G channel roughness, B channel metallic, each times its factor.
  vec4 metallicRoughness = texture(uMetallicRoughnessTexture, uv);
  float perceptualRoughness =
      clamp(uMaterialParams.y * metallicRoughness.g, MIN_ROUGHNESS, 1.0);
  float metallic = clamp(uMaterialParams.x * metallicRoughness.b, 0.0, 1.0);
  float alpha = perceptualRoughness * perceptualRoughness;

  // Occlusion: R channel, blended towards 1 by the occlusion strength; ambient only.
  float occlusionSample = texture(uOcclusionTexture, uv).r;
  float occlusion = 1.0 + uMaterialParams.w * (occlusionSample - 1.0);

  // Emissive: texture (sRGB) x factor, added unlit.
  vec3 emissive = srgbToLinear(texture(uEmissiveTexture, uv).rgb) * uEmissiveFactor.rgb;

  // --- shading normal: tangent-space normal map through the interpolated TBN frame ---
  // The xy components are scaled by the normal scale (glTF normalTexture.scale). The frame is
  // used unnormalised (MikkTSpace convention) so that a missing/degenerate tangent with the flat
  // default normal map (0,0,1) still yields the geometric normal.
  vec3 tangentNormal = texture(uNormalTexture, uv).xyz * 2.0 - 1.0;
  tangentNormal.xy *= uMaterialParams.z;
  vec3 geometricNormal = normalize(vWorldNormal);
  vec3 normal = normalize(tangentNormal.x * vWorldTangent + tangentNormal.y * vWorldBitangent +
                          tangentNormal.z * geometricNormal);
  // A back face is drawn only for a double-sided material (single-sided ones are culled); glTF
  // lights it with its normal reversed (glTF 2.0 §3.9.5, double sided).
  normal *= gl_FrontFacing ? 1.0 : -1.0;

  // --- directions ---
  vec3 viewDir = normalize(uCameraPosition.xyz - vWorldPosition);
  vec3 lightDir = normalize(uLightPosition.xyz - vWorldPosition);
  vec3 halfDir = normalize(lightDir + viewDir);
  float nDotL = clamp(dot(normal, lightDir), 0.0, 1.0);
  float nDotV = clamp(abs(dot(normal, viewDir)), 1e-4, 1.0);
  float nDotH = clamp(dot(normal, halfDir), 0.0, 1.0);
  float vDotH = clamp(dot(viewDir, halfDir), 0.0, 1.0);

  // --- metallic workflow: dielectrics reflect 4% with a coloured diffuse, metals tint the
  // specular with the base colour and have no diffuse ---
  vec3 f0 = mix(vec3(DIELECTRIC_F0), baseColor, metallic);
  vec3 diffuseColor = baseColor * (1.0 - metallic);

  // --- direct light: Cook-Torrance specular + Lambert diffuse ---
  vec3 fresnel = fresnelSchlick(f0, vDotH);
  float ndf = distributionGgx(nDotH, alpha);
  float visibility = visibilitySmithHeightCorrelated(nDotL, nDotV, alpha);
  vec3 specularBrdf = fresnel * (ndf * visibility);
  vec3 diffuseBrdf = (vec3(1.0) - fresnel) * diffuseColor / PI;
  // The point light has no falloff (INTERFACE.md). The factor PI makes uLightColor the radiance a
  // white Lambertian surface facing the light reflects, the same scale the Phong shaders use.
  vec3 direct = (diffuseBrdf + specularBrdf) * uLightColor.rgb * (PI * nDotL);

  // --- ambient: constant light on the diffuse colour plus a crude specular, both occluded ---
  vec3 ambientDiffuse = uAmbientColor.rgb * diffuseColor;
  vec3 ambientSpecular = uAmbientColor.rgb * ambientSpecularBrdf(f0, perceptualRoughness, nDotV);
  vec3 ambient = (ambientDiffuse + ambientSpecular) * occlusion;

  vec3 radiance = direct + ambient + emissive;

  // --- display: tone map, then encode for an sRGB display ---
  outColor = vec4(linearToSrgb(toneMapFilmic(radiance)), 1.0);
}
