// Params::particle_box and Params::clip_box: checking a box, and keeping the particles inside one.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// The box as "[x0, x1] x [y0, y1] x [z0, z1]" for messages.
std::string box_text(const Box& box);

/// Throws Error naming `what` ("particle box", "clip box") unless every bound is finite and
/// min < max on every axis.
void validate_box(const Box& box, const std::string& what);

/// Keeps the particles with min <= p <= max on every axis (in place, order kept) and their values
/// of every attribute; returns how many are kept. Throws Error when none is.
std::size_t keep_particles_in_box(std::vector<float>& xyz, std::vector<ParticleAttribute>& attributes, const Box& box);

}  // namespace trilevel
