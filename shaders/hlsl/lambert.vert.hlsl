// duolod example shader "lambert" in HLSL (vertex stage): what an HLSL author writes for duolod's
// interface (shaders/INTERFACE.md). Inputs take the mesh's streams by semantic (POSITION, NORMAL,
// TANGENT, TEXCOORD0/1, COLOR), cbuffers the interface's block bindings through register(bN); the
// varyings are the members of VertexOutput, matched to the pixel shader's inputs by semantic.
// Use it as `--vert shaders/hlsl/lambert.vert.hlsl --frag shaders/hlsl/lambert.frag.hlsl`.

cbuffer Frame : register(b0) {
  float4x4 uModel;          // object -> world
  float4x4 uView;           // world -> eye
  float4x4 uProjection;     // eye -> clip
  float4x4 uNormalMatrix;   // inverse-transpose of uModel (upper 3x3 used)
  float4 uCameraPosition;   // world space, w = 1
  float4 uLightPosition;    // world space point light, w = 1
  float4 uLightColor;       // rgb radiance scale; no distance falloff
  float4 uAmbientColor;     // rgb constant ambient
  float4 uObjectInfo;       // xyz bounding-sphere centre (object space), w its radius
};

struct VertexInput {
  float3 position : POSITION;
  float3 normal : NORMAL;
  float2 uv : TEXCOORD0;
};

struct VertexOutput {
  float4 position : SV_Position;
  float3 worldPosition : TEXCOORD0;
  float3 worldNormal : TEXCOORD1;
  float2 uv : TEXCOORD2;
};

// The matrices arrive as OpenGL lays them out; HLSL's default column_major packing reads them so
// that mul(M, v) is what GLSL's M * v is.
VertexOutput main(VertexInput input) {
  VertexOutput output;
  float4 world = mul(uModel, float4(input.position, 1.0));
  output.worldPosition = world.xyz;
  output.worldNormal = mul((float3x3)uNormalMatrix, input.normal);
  output.uv = input.uv;
  output.position = mul(uProjection, mul(uView, world));
  return output;
}
