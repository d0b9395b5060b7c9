#version 450 core
// duolod test shader "constant" (fragment stage): writes uBaseColorFactor.rgb unchanged (no
// lighting, tone mapping or sRGB encoding), alpha 1, so a test can predict every covered pixel.

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

layout(location = 0) out vec4 outColor;

void main() {
  outColor = vec4(uBaseColorFactor.rgb, 1.0);
}
