// The colour a pass writes into the target (forward.frag, the render features' views): scene-
// referred radiance exposed and tone mapped (the ACES filmic fit of Narkowicz 2015), data as it
// is; for UNORM targets the sRGB transfer; nothing of that into float targets (linear values).
// Included after common.glsl.

// ACES filmic curve, Narkowicz 2015 ("ACES Filmic Tone Mapping Curve"), per channel, to [0, 1].
vec3 tone_map(vec3 x) {
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb_encode(vec3 c) {
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

vec4 output_colour(vec3 color, bool scene_referred) {
  uint flags = frame.params.z;
  if ((flags & PENUMBRA_FLAG_LINEAR) == 0u) {
    if (scene_referred) color = tone_map(color * frame.camera_exposure.w);
    color = clamp(color, 0.0, 1.0);
    if ((flags & PENUMBRA_FLAG_ENCODE_SRGB) != 0u) color = srgb_encode(color);
  }
  return vec4(color, 1.0);
}
