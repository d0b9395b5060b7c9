#version 450 core
// duolod reference shader "noise_phong" (fragment stage): the paper's Dragon shader
// (Sitthi-Amorn et al. 2011) rebuilt for this interface.
//   texture:  4-octave fBm of 3D gradient noise (Perlin 2002, "Improving Noise": quintic fade,
//             12 cube-edge gradients) evaluated on the object-space position in units of the
//             bounding-sphere radius, so the pattern has the same scale on every asset;
//   pattern:  noise-warped sine veins (Perlin 1985 marble) over a 3-colour stone ramp;
//   normal:   bump-mapped by the analytic fBm gradient;
//   lighting: Phong (Phong 1975) diffuse + specular from the point light, constant ambient;
//   output:   exposure 1, filmic tone curve (Narkowicz 2015 fit of ACES), sRGB encoding.
// The noise lattice is hashed arithmetically (no texture lookups), which makes every octave
// ~8 hashes + 8 gradient dot products + a trilinear blend of values and derivatives: this is
// the expensive per-pixel work LOD simplification is meant to trade away. The base frequency
// puts lattice cells a few pixels wide at typical sizes, so the pattern aliases without
// supersampling.

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

// ---- stage inputs ----
layout(location = 0) in vec3 vWorldPosition;
layout(location = 1) in vec3 vObjectPosition;
layout(location = 2) in vec3 vObjectNormal;

layout(location = 0) out vec4 outColor;

// ---- knobs ----
const int OCTAVES = 4;                 // fBm octaves (constant trip count)
const float BASE_FREQUENCY = 4.0;      // lattice cells per bounding-sphere radius, octave 0
const float LACUNARITY = 2.07;         // frequency ratio between octaves (not 2: hides the lattice)
const float GAIN = 0.5;                // amplitude ratio between octaves
const float VEIN_FREQUENCY = 9.0;      // sine veins per radius, before warping (radians/radius)
const float VEIN_WARP = 2.0;           // how strongly the fBm bends the veins
const float VEIN_SHARPNESS = 10.0;     // exponent thinning the vein cores (~1 px wide: aliases)
const float VEIN_HALO_SHARPNESS = 2.5;  // exponent of the soft band around each vein
const float BUMP_HEIGHT = 0.012;       // bump amplitude in units of the radius
const float SHININESS = 48.0;          // Phong specular exponent
const float EXPOSURE = 1.0;

// Stone ramp, linear rgb: light limestone, warm grey clouding, dark green-grey veins.
const vec3 STONE_LIGHT = vec3(0.66, 0.61, 0.53);
const vec3 STONE_CLOUD = vec3(0.30, 0.27, 0.24);
const vec3 STONE_VEIN = vec3(0.03, 0.05, 0.045);

// ---- procedural noise ----

// Integer hash of a lattice point: three rounds of a PCG-style LCG step and cross-multiplication
// of the coordinates with a xorshift in between (after Jarzynski & Olano 2020, "Hash Functions
// for GPU Rendering"). Only arithmetic, so the lattice is unbounded and needs no texture.
uint hashLattice(ivec3 cell) {
  uvec3 v = uvec3(cell) * 1664525u + 1013904223u;
  v.x += v.y * v.z;
  v.y += v.z * v.x;
  v.z += v.x * v.y;
  v ^= v >> 16u;
  v.x += v.y * v.z;
  v.y += v.z * v.x;
  v.z += v.x * v.y;
  return v.x ^ v.y ^ v.z;
}

// Perlin's improved-noise gradient set: the 12 cube-edge directions (+-1,+-1,0), (+-1,0,+-1),
// (0,+-1,+-1), padded to 16 by repeating four of them, chosen by 4 hash bits. Written with
// selects instead of branches: u is x (h < 8) or y; v is y (h < 4), x (h = 12, 14) or z;
// bit 0 negates u, bit 1 negates v.
vec3 latticeGradient(uint hash) {
  uint h = hash >> 28u; // the best-mixed bits
  float uIsX = float(h < 8u);
  vec3 uAxis = vec3(uIsX, 1.0 - uIsX, 0.0);
  float vIsY = float(h < 4u);
  float vIsX = float(h == 12u) + float(h == 14u);
  vec3 vAxis = vec3(vIsX, vIsY, 1.0 - vIsX - vIsY);
  float uSign = 1.0 - 2.0 * float(h & 1u);
  float vSign = 1.0 - float(h & 2u);
  return uSign * uAxis + vSign * vAxis;
}

// 3D gradient noise with its analytic gradient: returns (value, d/dx, d/dy, d/dz).
// Each corner contributes the linear ramp dot(g, p - corner); the ramps are blended with the
// quintic fade 6t^5 - 15t^4 + 10t^3 (C2-continuous, Perlin 2002). Writing the trilinear blend
// as k0 + k1 u.x + k2 u.y + k3 u.z + k4 u.x u.y + k5 u.y u.z + k6 u.z u.x + k7 u.x u.y u.z lets
// the derivative be taken term by term.
vec4 gradientNoise(vec3 p) {
  vec3 cellFloor = floor(p);
  ivec3 cell = ivec3(cellFloor);
  vec3 f = p - cellFloor;

  vec3 fade = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
  vec3 fadeDerivative = 30.0 * f * f * (f * (f - 2.0) + 1.0);

  // gradients at the eight cell corners
  vec3 g000 = latticeGradient(hashLattice(cell + ivec3(0, 0, 0)));
  vec3 g100 = latticeGradient(hashLattice(cell + ivec3(1, 0, 0)));
  vec3 g010 = latticeGradient(hashLattice(cell + ivec3(0, 1, 0)));
  vec3 g110 = latticeGradient(hashLattice(cell + ivec3(1, 1, 0)));
  vec3 g001 = latticeGradient(hashLattice(cell + ivec3(0, 0, 1)));
  vec3 g101 = latticeGradient(hashLattice(cell + ivec3(1, 0, 1)));
  vec3 g011 = latticeGradient(hashLattice(cell + ivec3(0, 1, 1)));
  vec3 g111 = latticeGradient(hashLattice(cell + ivec3(1, 1, 1)));

  // the corners' linear ramps evaluated at p
  float n000 = dot(g000, f - vec3(0.0, 0.0, 0.0));
  float n100 = dot(g100, f - vec3(1.0, 0.0, 0.0));
  float n010 = dot(g010, f - vec3(0.0, 1.0, 0.0));
  float n110 = dot(g110, f - vec3(1.0, 1.0, 0.0));
  float n001 = dot(g001, f - vec3(0.0, 0.0, 1.0));
  float n101 = dot(g101, f - vec3(1.0, 0.0, 1.0));
  float n011 = dot(g011, f - vec3(0.0, 1.0, 1.0));
  float n111 = dot(g111, f - vec3(1.0, 1.0, 1.0));

  // polynomial coefficients of the trilinear blend
  float k0 = n000;
  float k1 = n100 - n000;
  float k2 = n010 - n000;
  float k3 = n001 - n000;
  float k4 = n000 - n100 - n010 + n110;
  float k5 = n000 - n010 - n001 + n011;
  float k6 = n000 - n100 - n001 + n101;
  float k7 = -n000 + n100 + n010 - n110 + n001 - n101 - n011 + n111;

  vec3 gk0 = g000;
  vec3 gk1 = g100 - g000;
  vec3 gk2 = g010 - g000;
  vec3 gk3 = g001 - g000;
  vec3 gk4 = g000 - g100 - g010 + g110;
  vec3 gk5 = g000 - g010 - g001 + g011;
  vec3 gk6 = g000 - g100 - g001 + g101;
  vec3 gk7 = -g000 + g100 + g010 - g110 + g001 - g101 - g011 + g111;

  float value = k0 + k1 * fade.x + k2 * fade.y + k3 * fade.z + k4 * fade.x * fade.y +
                k5 * fade.y * fade.z + k6 * fade.z * fade.x + k7 * fade.x * fade.y * fade.z;

  // d/dp = (blend of the corner gradients) + (derivative of the blend weights)
  vec3 blendedGradient = gk0 + gk1 * fade.x + gk2 * fade.y + gk3 * fade.z +
                         gk4 * fade.x * fade.y + gk5 * fade.y * fade.z +
                         gk6 * fade.z * fade.x + gk7 * fade.x * fade.y * fade.z;
  vec3 weightDerivative = fadeDerivative *
      vec3(k1 + k4 * fade.y + k6 * fade.z + k7 * fade.y * fade.z,
           k2 + k5 * fade.z + k4 * fade.x + k7 * fade.z * fade.x,
           k3 + k6 * fade.x + k5 * fade.y + k7 * fade.x * fade.y);

  return vec4(value, blendedGradient + weightDerivative);
}

// Fractional Brownian motion: OCTAVES octaves of gradient noise, each at LACUNARITY times the
// frequency and GAIN times the amplitude of the previous one. q is in radius units; returns the
// sum and its gradient with respect to q. Each octave is shifted so the octaves' lattices do not
// share an origin.
vec4 fbm(vec3 q) {
  vec4 sum = vec4(0.0);
  float amplitude = 0.5;
  float frequency = BASE_FREQUENCY;
  for (int octave = 0; octave < OCTAVES; ++octave) {
    vec3 shift = float(octave) * vec3(17.31, 5.97, 29.53);
    vec4 n = gradientNoise(q * frequency + shift);
    sum += amplitude * vec4(n.x, n.yzw * frequency);
    amplitude *= GAIN;
    frequency *= LACUNARITY;
  }
  return sum;
}

// ---- display ----

vec3 toneMapFilmic(vec3 hdr) {
  vec3 x = hdr * EXPOSURE;
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 linearToSrgb(vec3 linearColor) {
  vec3 low = linearColor * 12.92;
  vec3 high = 1.055 * pow(linearColor, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, lessThanEqual(linearColor, vec3(0.0031308)));
}

void main() {
  // --- solid texture coordinates: object space, centred and in units of the radius ---
  float radius = max(uObjectInfo.w, 1e-6);
  vec3 q = (vObjectPosition - uObjectInfo.xyz) / radius;

  // --- texture function ---
  vec4 turbulence = fbm(q); // x value (std ~0.16, |x| < ~0.6), yzw gradient w.r.t. q

  // Veins: a sine along a slanted axis whose phase is warped by the fBm; 1 - |sin| peaks where
  // the sine crosses zero, a high exponent thins those peaks into sharp dark lines and a low one
  // gives the soft darker band around them.
  const vec3 veinAxis = vec3(0.80, 0.28, 0.53);
  float veinPhase = VEIN_FREQUENCY * dot(q, veinAxis) + VEIN_WARP * turbulence.x;
  float veinProfile = 1.0 - abs(sin(veinPhase));
  float vein = pow(veinProfile, VEIN_SHARPNESS);
  float veinHalo = pow(veinProfile, VEIN_HALO_SHARPNESS);

  // Colour ramp: limestone clouded grey by the noise (halo adds to the clouding), then the veins.
  float clouding = smoothstep(-0.2, 0.25, turbulence.x);
  vec3 stone = mix(STONE_LIGHT, STONE_CLOUD, clamp(clouding + 0.5 * veinHalo, 0.0, 1.0));
  vec3 albedo = mix(stone, STONE_VEIN, vein);

  // --- bump mapping: treat BUMP_HEIGHT * radius * fBm as a height along the normal; its
  // object-space gradient is BUMP_HEIGHT * d fBm/dq. Tilt the normal against the gradient's
  // tangential part, then take it to world space with the normal matrix ---
  vec3 objectNormal = normalize(vObjectNormal);
  vec3 heightGradient = BUMP_HEIGHT * turbulence.yzw;
  vec3 surfaceGradient = heightGradient - dot(heightGradient, objectNormal) * objectNormal;
  vec3 bumpedObjectNormal = normalize(objectNormal - surfaceGradient);
  vec3 normal = normalize(mat3(uNormalMatrix) * bumpedObjectNormal);
  // glTF double-sided materials: back faces are lit with the normal reversed (see pbr.frag).
  normal *= gl_FrontFacing ? 1.0 : -1.0;

  // --- Phong (1975): diffuse n.l, specular (r.v)^shininess with r the mirrored light ---
  vec3 viewDir = normalize(uCameraPosition.xyz - vWorldPosition);
  vec3 lightDir = normalize(uLightPosition.xyz - vWorldPosition);
  float nDotL = dot(normal, lightDir);
  float diffuse = max(nDotL, 0.0);
  vec3 reflected = reflect(-lightDir, normal);
  float specular = pow(max(dot(reflected, viewDir), 0.0), SHININESS) * step(0.0, nDotL);
  // polished calcite: veins (filled cracks) are a little less glossy than the stone
  float specularStrength = mix(0.35, 0.2, vein);

  vec3 radiance = uLightColor.rgb * (albedo * diffuse + specularStrength * specular) +
                  uAmbientColor.rgb * albedo;

  outColor = vec4(linearToSrgb(toneMapFilmic(radiance)), 1.0);
}
