"""The parts every ray caster is made of, one concept per module:

- ``geometry``: world <-> texture space, the volume's boxes, camera planes and ray uniforms, the
  concrete camera of a frame;
- ``textures``: the volume's trilinear sampler and the LUT textures (transfer functions, colour maps);
- ``empty_space``: block ranges and skip radii, and what a ray caster should show;
- ``targets``: output images kept across evaluations;
- ``light``: Blinn-Phong uniforms;
- ``components``: the ray-casting components and ``RaycasterBase``, which the ray casters are built
  from (docs/explanations/architecture.md).
"""
