#version 450 core
// duolod reference shader "noise_phong" (vertex stage): procedural marble, Phong-lit (the
// Dragon shader of Sitthi-Amorn et al. 2011). The texture function is evaluated per pixel in
// object space, so the object-space position and normal are passed on alongside the world-space
// position used for lighting. Interface: shaders/INTERFACE.md.

// ---- vertex attributes (INTERFACE.md) ----
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inTangent;
layout(location = 3) in vec2 inUV0;
layout(location = 4) in vec2 inUV1;
layout(location = 5) in vec4 inColor;

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

// ---- stage outputs ----
layout(location = 0) out vec3 vWorldPosition;
layout(location = 1) out vec3 vObjectPosition; // where the solid texture is evaluated
layout(location = 2) out vec3 vObjectNormal;   // perturbed per pixel, then taken to world space

void main() {
  vec4 worldPosition = uModel * vec4(inPosition, 1.0);
  vWorldPosition = worldPosition.xyz;
  vObjectPosition = inPosition;
  vObjectNormal = inNormal;
  gl_Position = uProjection * (uView * worldPosition);
}
