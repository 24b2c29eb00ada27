// LIGHT_VOLUME: volumetric shadows from the RayCaster's light_volume inport (a LightVolume's
// transmittance T of a directional light, vgraph.numerics.light_volume). A sample's colour, shaded
// or not, becomes rgb * (1 - shadow_strength * (1 - T)) with T the light volume's normalised
// intensity, trilinear at the sample: its texture coordinate is the volume's, mapped per axis by
// light_volume_scale and light_volume_offset (the two grids share a box frame, not their voxels).
// Rule 9 of the CPU reference (vgraph.numerics.reference_raycast) is the same.
#ifdef LIGHT_VOLUME
uniform sampler3D light_volume;
uniform vec3 light_volume_scale;
uniform vec3 light_volume_offset;
uniform float light_intensity_scale;   // T = texel * scale + offset
uniform float light_intensity_offset;
uniform float shadow_strength;

vec3 shadowed(vec3 rgb, vec3 t) {
    float texel = textureLod(light_volume, t * light_volume_scale + light_volume_offset, 0.0).r;
    float transmittance = clamp(texel * light_intensity_scale + light_intensity_offset, 0.0, 1.0);
    return rgb * (1.0 - shadow_strength * (1.0 - transmittance));
}
#endif
