#version 330
// What a ray caster writes where every ray misses, drawn before its pass is cut to the box's
// footprint (RaycasterBase.draw's ``missed``). A draw, not a clear: with a clear of the outputs
// before each pass, llvmpipe's resident memory swung by whole volume textures from frame to frame
// (tests/test_leaks.py caught it); with this draw it stays flat.
uniform vec4 missed0;
uniform vec4 missed1;

layout(location = 0) out vec4 output0;
layout(location = 1) out vec4 output1;

void main() {
    output0 = missed0;
    output1 = missed1;
}
