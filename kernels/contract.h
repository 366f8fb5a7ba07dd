// The host-kernel contract: every value the OpenCL kernels and the C++ host must agree on, in one
// file read by both. The kernels get it as the first part of their program source (the ordered
// list in kernels/kernels.cmake); the host includes it through src/kernel_contract.hpp, which
// gives the values C++ types. Plain #defines of literals only, so that it is valid OpenCL C and C++.
// Values the host computes at run time (MAX_CANDIDATES, SERIAL_GATHER, FINE_KEY_BITS) and the
// calibrated constants of src/stage_constants.hpp come as build options instead.
#ifndef TRILEVEL_KERNEL_CONTRACT_H
#define TRILEVEL_KERNEL_CONTRACT_H

// Particle flags (one byte a sorted particle; color_field.cl writes them).
#define FLAG_SURFACE 1  /* surface particle: |colour-field gradient| R above SURFACE_GRADIENT */
#define FLAG_SPLASH 2   /* fewer than SPLASH_NEIGHBOURS neighbours */
#define FLAG_THIN 4     /* fewer than THIN_NEIGHBOURS neighbours: a small cluster, filament or sheet */

// Coarse cell flags (one uint a cell slot; surface_cells.cl writes them).
#define CELL_SPLASH 1  /* within the box of a splash or thin particle: forced level 3 */
#define CELL_INTERIOR 2  /* holds a particle that is neither surface, splash nor thin */
#define CELL_THIN_BODY 4  /* no cell of its 3 x 3 x 3 block holds one: a rod, sheet or droplet */

// A cell's w in the int4 cell lists (x, y, z = coarse coordinates): its level in the low two bits,
// plus CELL_CUBE_CENTRES where the level-2 check needs the centres of its level-2 cubes.
#define CELL_LEVEL_MASK 3
#define CELL_CUBE_CENTRES 4
// From bit CELL_ABOVE_SHIFT, two bits for each of the 7 cells above it in the same list (d = 1..7:
// +x by bit 0 of d, +y by bit 1, +z by bit 2, at bits CELL_ABOVE_SHIFT + 2 (d - 1)): the first
// when that cell is in the list, the second when it is level 3 (scalar_field.cl, held_above).
#define CELL_ABOVE_SHIFT 3

// Bins a work-group's candidate gather spans at most (gather_candidates: its __local bin lists).
#define MAX_BINS 64

// Lattice points one coarse cell holds at most, (8 + 1)^3 for the uniform cell r/2 (the __local
// list of claimed points of scalar_field_cells).
#define MAX_CELL_POINTS 729

// Which points of its cell a work-group of scalar_field_cells claims (ClaimPoints on the host).
#define CLAIM_LEVEL 0            /* the pending points of the cell's level (and its cube centres) */
#define CLAIM_EDGE_MIDPOINTS 1   /* the pending midpoints of its level-2 edges (edge refinement) */
#define CLAIM_INSERTED 2         /* inserts the points of its level, takes those it created */
#define CLAIM_REFINED_EDGES 3    /* inserts the midpoints of its crossed level-2 edges (edge refinement), takes those it created */

// Fixed-point scale of the per-cell curvature sums (curvature.cl): 2^20, so that the sums do not
// depend on the order of the atomic adds.
#define KAPPA_FIXED 1048576.0f

#endif
