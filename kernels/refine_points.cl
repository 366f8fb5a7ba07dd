// refine_points.cl (to be written)
