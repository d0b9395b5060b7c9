#version 450 core
// duolod reference shader "pbr" (vertex stage): glTF 2.0 metallic-roughness.
// Moves the surface frame (position, normal, tangent, bitangent) to world space for per-pixel
// lighting and normal mapping. Interface: shaders/INTERFACE.md.

// ---- vertex attributes (INTERFACE.md) ----
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inTangent; // w = bitangent sign
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
layout(location = 1) out vec3 vWorldNormal;
layout(location = 2) out vec3 vWorldTangent;
layout(location = 3) out vec3 vWorldBitangent;
layout(location = 4) out vec2 vUV0;
layout(location = 5) out vec4 vColor;

void main() {
  vec4 worldPosition = uModel * vec4(inPosition, 1.0);
  vWorldPosition = worldPosition.xyz;

  // Normals transform with the inverse-transpose; tangents are surface directions and transform
  // with the model matrix itself.
  vec3 normal = normalize(mat3(uNormalMatrix) * inNormal);
  vec3 tangent = normalize(mat3(uModel) * inTangent.xyz);

  // glTF: bitangent = cross(normal, tangent) * tangent.w (the sign encodes UV mirroring).
  // Not normalised here or per pixel (MikkTSpace convention): only the perturbed normal is.
  vWorldNormal = normal;
  vWorldTangent = tangent;
  vWorldBitangent = cross(normal, tangent) * inTangent.w;

  vUV0 = inUV0;
  vColor = inColor;
  gl_Position = uProjection * (uView * worldPosition);
}
