#version 330
// What a ray caster writes where every ray misses, drawn before its pass is cut to the box's
// footprint (RaycasterBase.draw's ``missed``): a draw, not a clear, because llvmpipe gives a
// texture that is cleared while queued work still reads it new storage, so memory swung by whole
// images per frame (vgraph.leaks).
uniform vec4 missed0;
uniform vec4 missed1;

layout(location = 0) out vec4 output0;
layout(location = 1) out vec4 output1;

void main() {
    output0 = missed0;
    output1 = missed1;
}
