"""Projected tetrahedra (Shirley & Tuchman 1990; Monsalve 2016 ch. 2-4): the projection classes of
a tetrahedron seen from the camera (projection.py), the back-to-front visibility order
(order.py) and the pre-integrated segment table (preintegration.py). The ProjectedTetrahedra
processor (processors/projected_tetrahedra.py) draws with shaders/tetrahedra/*.glsl."""
