// surface_cells.cl (to be written)
