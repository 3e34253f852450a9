#version 300 es
precision highp float;
precision highp int;
uniform sampler2D uTex0;   // rgb: base colour, sRGB codes / 255; a: specular (linear)
uniform sampler2D uTex1;   // rgb: stored normal (n + 1) / 2; a: roughness
uniform sampler2D uTex2;   // r: height (0.5 = mean level), g: ambient occlusion (1 = open); read when uHasRelief
uniform int uHasRelief;
uniform float uRelief;     // height gain: 0 flat, 1 the true scale
uniform float uHeightScale;  // the height black to white spans, map widths (= 2 scene units)
uniform float uAmbient;    // ambient sky radiance, in units of intensity / pi
uniform vec2 uSize;        // maps (W, H)
uniform vec2 uCanvas;      // drawing buffer (W, H)
uniform float uReps;       // plane half-width in half-photo-widths: 1 = the photo, N = N x N repeats
uniform int uExact;        // 1: one canvas pixel per map pixel, read with texelFetch
uniform vec3 uLight;
uniform float uCamD;       // d of the render config
uniform float uIntensity;
uniform int uFalloff;
uniform int uConserve;
uniform int uGeometry;     // 0 schlick, 1 smith
uniform int uFresnel;      // 0 schlick, 1 none
uniform float uDx;         // -1: stored normals are DirectX (y down)
uniform float uExposure;
out vec4 outColor;

const float PI = 3.141592653589793;
const float ALPHA_MIN = @ALPHA_MIN@;
const float COS_EPS = @COS_EPS@;
const float NORM_EPS = @NORM_EPS@;

vec3 normalize3(vec3 a) { return a * inversesqrt(dot(a, a) + NORM_EPS); }

float srgbToLinear(float c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }
float linearToSrgb(float c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055; }

void main() {
  vec2 fc = gl_FragCoord.xy;  // pixel centres, origin at the bottom left
  // render(): x = 2 (j + 0.5) / W - 1, y = (H / W)(1 - 2 (i + 0.5) / H), i counted from the top
  float x = uReps * (2.0 * fc.x / uCanvas.x - 1.0);
  float y = uReps * (2.0 * fc.y - uCanvas.y) / uCanvas.x;
  vec3 p = vec3(x, y, 0.0);
  vec3 cam = vec3(0.0, 0.0, uReps * uCamD);
  vec3 v = normalize(cam - p);
  bool lift = uHasRelief == 1 && uRelief != 0.0;
  vec4 t0, t1, t2 = vec4(0.5, 1.0, 0.0, 1.0);
  if (uExact == 1) {
    ivec2 ij = ivec2(int(fc.x), int(uSize.y) - 1 - int(fc.y));
    if (lift) {  // parallax offset: where the view ray meets the height z of this pixel
      float z = uRelief * uHeightScale * 2.0 * (texelFetch(uTex2, ij, 0).r - 0.5);
      p = vec3(p.xy + z * v.xy / v.z, z);
      ivec2 s = ivec2(uSize);
      ij = ivec2(floor(vec2((p.x + 1.0) * 0.5, (1.0 - p.y * uSize.x / uSize.y) * 0.5) * uSize));
      ij = ((ij % s) + s) % s;
    }
    t0 = texelFetch(uTex0, ij, 0);
    t1 = texelFetch(uTex1, ij, 0);
    if (uHasRelief == 1) t2 = texelFetch(uTex2, ij, 0);
  } else {
    vec2 uv = vec2((x + 1.0) * 0.5, (1.0 - y * uSize.x / uSize.y) * 0.5);  // repeats wrap (REPEAT)
    if (lift) {
      float z = uRelief * uHeightScale * 2.0 * (texture(uTex2, uv).r - 0.5);
      p = vec3(p.xy + z * v.xy / v.z, z);
      uv = vec2((p.x + 1.0) * 0.5, (1.0 - p.y * uSize.x / uSize.y) * 0.5);
    }
    t0 = texture(uTex0, uv);
    t1 = texture(uTex1, uv);
    if (uHasRelief == 1) t2 = texture(uTex2, uv);
  }
  vec3 diffuse = vec3(srgbToLinear(t0.r), srgbToLinear(t0.g), srgbToLinear(t0.b));
  float specular = t0.a;
  float roughness = t1.a;
  // decode_normal: 2 v - 1, z >= 0, unit length (a zero vector -> (0, 0, 1)); DirectX -> OpenGL
  vec3 nd = t1.rgb * 2.0 - 1.0;
  nd.y *= uDx;
  nd.z = max(nd.z, 0.0);
  float nlen = length(nd);
  vec3 n = nlen < 1e-8 ? vec3(0.0, 0.0, 1.0) : nd / nlen;

  vec3 ld = uLight - p;
  float light_dist2 = dot(ld, ld);
  vec3 l = ld / sqrt(light_dist2);

  // shade()
  n = normalize3(n);
  vec3 h = normalize3(v + l);
  float n_l = max(dot(n, l), COS_EPS);
  float n_v = max(dot(n, v), COS_EPS);
  float n_h = max(dot(n, h), COS_EPS);
  float v_h = max(dot(v, h), COS_EPS);
  float alpha = max(roughness * roughness, ALPHA_MIN);
  float a2 = alpha * alpha;
  float denom = n_h * n_h * (a2 - 1.0) + 1.0;
  float d_term = a2 / (PI * denom * denom);
  float vis;
  if (uGeometry == 0) {
    float k = alpha * 0.5;
    vis = 1.0 / ((n_l * (1.0 - k) + k) * (n_v * (1.0 - k) + k));
  } else {
    float g1_l = 2.0 / (1.0 + sqrt(a2 + (1.0 - a2) * n_l * n_l) / n_l);
    float g1_v = 2.0 / (1.0 + sqrt(a2 + (1.0 - a2) * n_v * n_v) / n_v);
    vis = g1_l * g1_v / (n_l * n_v);
  }
  float fres = uFresnel == 0 ? specular + (1.0 - specular) * exp2((-5.55473 * v_h - 6.98316) * v_h) : specular;
  float light = uIntensity * n_l;
  if (uFalloff == 1) { light = light * (uCamD * uCamD) / light_dist2; }
  float spec_radiance = light * fres * vis * d_term * 0.25;
  float diff_weight = light / PI;
  if (uConserve == 1) { diff_weight = diff_weight * (1.0 - specular); }
  vec3 radiance = diff_weight * diffuse + spec_radiance;
  radiance += (uAmbient * uIntensity / PI * t2.g) * diffuse;  // ambient sky, occluded by the AO (0 by default)

  vec3 c = clamp(radiance * uExposure, 0.0, 1.0);
  outColor = vec4(linearToSrgb(c.r), linearToSrgb(c.g), linearToSrgb(c.b), 1.0);
}
