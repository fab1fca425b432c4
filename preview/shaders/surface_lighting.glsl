// The lighting of a bump-mapped surface point, shared by swatch.frag and
// scan_surface.frag; shading.cpp's shade() is its CPU twin (keep the three
// in step). Tangent space, linear light: ambient + Lambert diffuse +
// Blinn-Phong specular scaled by the gloss. Normal-map prefiltering after
// Toksvig 2005 ("Mipmapping normal maps", J. Graphics Tools 10(3)): a
// mipmap level's normals are averaged without renormalising
// (texture_levels.h), the averaged normal's length |N| says how spread the
// normals under the texel are, and the exponent s becomes f s with
// f = |N| / (|N| + s (1 - |N|)), so a distant bumpy surface keeps the
// wider highlight the bumps make instead of a mirror's sparkle.
precision highp float;

uniform float u_diffuse;
uniform float u_specular;
uniform float u_shininess;

// `ambient`: what is seen without the lamp, a share of the albedo;
// `direct`: the lamp's colour times its attenuation.
vec3 surface_lighting(vec3 albedo, vec4 normal_gloss, vec3 to_light, vec3 to_eye, vec3 ambient,
                      vec3 direct) {
  vec3 light = normalize(to_light);
  vec3 eye = normalize(to_eye);
  float len = max(length(normal_gloss.xyz), 1e-4);
  vec3 normal = normal_gloss.xyz / len;
  float toksvig = len / (len + u_shininess * (1.0 - len));
  float exponent = max(toksvig * u_shininess, 1.0);
  // The macro surface shadows what lies beneath its plane, softly.
  float horizon = clamp(light.z * 4.0, 0.0, 1.0);
  // The averaged (unnormalised) normal gives the mean Lambert term.
  float lambert = max(dot(normal_gloss.xyz, light), 0.0);
  vec3 half_vector = normalize(light + eye);
  float facing = dot(normal, light) > 0.0 ? 1.0 : 0.0;
  float highlight = facing * (exponent + 2.0) / (u_shininess + 2.0) *
                    pow(max(dot(normal, half_vector), 0.0), exponent);
  direct *= horizon;
  return albedo * (ambient + u_diffuse * lambert * direct) +
         u_specular * normal_gloss.a * highlight * direct;
}
