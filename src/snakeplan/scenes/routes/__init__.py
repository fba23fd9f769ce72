"""Routes through a scene's free space (mm), for the scene generators' reach checks, ``sp-rrt`` and the learned
planners and their environments; one concept per module:

- :mod:`.grid`: the free-space grid (:class:`~.grid.Grid`, :func:`~.grid.free_space`, :class:`~.grid.FieldDeadline`);
- :mod:`.geodesic`: the any-angle geodesic distance from the entrance (:class:`~.geodesic.GeodesicField`,
  :func:`~.geodesic.geodesic_from_sdf`, :func:`~.geodesic.geodesic_field`; lazy Theta*, numba);
- :mod:`.guide`: route guides through the known obstacles (:class:`~.guide.RouteGuide`, :class:`~.guide.FreeSpace`,
  :func:`~.guide.route_guide`, :func:`~.guide.route_through`, :func:`~.guide.nearest_on_guide`).
"""
