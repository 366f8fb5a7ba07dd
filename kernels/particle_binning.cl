// particle_binning.cl (to be written)
