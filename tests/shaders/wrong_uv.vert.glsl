#version 330
// Test fixture: writes uv as vec3, which does not match uv.frag.glsl's 'in vec2 uv' (link error).
out vec3 uv;
void main() {
    uv = vec3(0.0);
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
