#version 330
// DepthDarkening (Luft, Colditz and Deussen 2006): the unsharp mask of the depth,
// delta = G * D - D (negative where a pixel lies behind its surroundings), darkens the colour:
// rgb + strength * min(delta, 0), kept >= 0; alpha unchanged. D is the depth image's red channel
// (window depth, 1 where no sample: the background is far) normalised to [0, 1] by the image's
// own depth range [depth_min, depth_max], so `strength` does not depend on the camera's near/far.
uniform sampler2D image;
uniform sampler2D depth;
uniform sampler2D blurred_depth;  // depth blurred by the Gaussian of image/gaussian_pass.glsl
uniform float depth_min;
uniform float depth_range;        // depth_max - depth_min, > 0
uniform float strength;
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 original = texelFetch(image, pixel, 0);
    float delta = (texelFetch(blurred_depth, pixel, 0).r - texelFetch(depth, pixel, 0).r) / depth_range;
    color = vec4(max(original.rgb + strength * min(delta, 0.0), 0.0), original.a);
}
