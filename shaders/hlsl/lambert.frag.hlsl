// duolod example shader "lambert" in HLSL (pixel stage): base colour factor × base colour texture,
// Lambert-lit by the interface's point light plus ambient, gamma 2.2. The texture and its sampler
// become one sampler2D at the texture's binding (register(t0): the base colour texture).

cbuffer Frame : register(b0) {
  float4x4 uModel;
  float4x4 uView;
  float4x4 uProjection;
  float4x4 uNormalMatrix;
  float4 uCameraPosition;
  float4 uLightPosition;
  float4 uLightColor;
  float4 uAmbientColor;
  float4 uObjectInfo;
};

cbuffer Material : register(b1) {
  float4 uBaseColorFactor;  // linear rgba
  float4 uEmissiveFactor;
  float4 uMaterialParams;
  float4 uTextureFlags;
  float4 uTextureFlags2;
};

Texture2D uBaseColorTexture : register(t0);
SamplerState uBaseColorSampler : register(s0);

struct VertexOutput {
  float4 position : SV_Position;
  float3 worldPosition : TEXCOORD0;
  float3 worldNormal : TEXCOORD1;
  float2 uv : TEXCOORD2;
};

float4 main(VertexOutput input) : SV_Target {
  float3 n = normalize(input.worldNormal);
  float3 l = normalize(uLightPosition.xyz - input.worldPosition);
  float3 albedo = uBaseColorFactor.rgb * uBaseColorTexture.Sample(uBaseColorSampler, input.uv).rgb;
  float3 lit = albedo * (uAmbientColor.rgb + uLightColor.rgb * max(dot(n, l), 0.0));
  return float4(pow(saturate(lit), 1.0 / 2.2), 1.0);
}
