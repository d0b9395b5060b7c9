#version 450 core
// duolod test shader "constant" (vertex stage): position only. Used by the renderer tests, which
// need an image whose every covered pixel has a known value. Interface: shaders/INTERFACE.md.

layout(location = 0) in vec3 inPosition;

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

void main() {
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
