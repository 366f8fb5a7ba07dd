// curvature.cl (to be written)
