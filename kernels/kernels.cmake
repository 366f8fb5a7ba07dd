# The OpenCL program, in the order its parts are joined: each file uses only what the files before
# it define (contract.h: the host-kernel contract; hash_table.cl: keys and the lock-free tables;
# particle_binning.cl: bins and the candidate gather; then one stage per file). CMake embeds them
# in this order (cmake/EmbedKernels.cmake) and the runtime builds the joined text as one program.
set(TRILEVEL_KERNEL_SOURCES
  contract.h
  hash_table.cl
  particle_binning.cl
  color_field.cl
  surface_cells.cl
  curvature.cl
  refine_points.cl
  scalar_field.cl)
# The device-input program (positions in a caller's buffer, Reconstructor::reconstruct on
# DevicePositions): built on its own, on first use, because it needs double precision.
set(TRILEVEL_DEVICE_INPUT_SOURCES
  device_input.cl)
