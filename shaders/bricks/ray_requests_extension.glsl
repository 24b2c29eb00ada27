// RayRequests (vgraph.bricks.ray_requests): the image atomics its requests count with. An
// #extension line must come ahead of every declaration, so this part is included first of all.
#extension GL_ARB_shader_image_load_store : enable
